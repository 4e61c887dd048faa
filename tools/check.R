# R CMD check of the package as a user would get it: installs what is
# missing (tools/deps.R), builds the tarball (vignettes included), runs
# `R CMD check --no-manual --no-tests` on it (the test command,
# tools/test.R, runs the tests) and fails on any ERROR or WARNING. NOTEs
# are printed and allowed. Run from the package root: Rscript tools/check.R
source("tools/deps.R")
R <- file.path(R.home("bin"), "R")
out <- tempfile("fbc-check-")
dir.create(out)
desc <- read.dcf("DESCRIPTION")
tarball <- file.path(out, sprintf("%s_%s.tar.gz", desc[, "Package"], desc[, "Version"]))
# R CMD build writes the tarball into the working directory: build in `out`
# (nothing is left in the checkout, whatever file system each is on)
pkg <- normalizePath(".")
old <- setwd(out)
build_status <- system2(R, c("CMD", "build", "--no-manual", shQuote(pkg)))
setwd(old)
if (build_status != 0 || !file.exists(tarball)) stop("R CMD build failed")
# no time server is reachable on CI machines; Suggests that are missing
# (bayesplot, loo) only skip the examples and tests that use them
env <- c("_R_CHECK_SYSTEM_CLOCK_=0", "_R_CHECK_FORCE_SUGGESTS_=false", "NOT_CRAN=true")
status <- system2(R, c("CMD", "check", "--no-manual", "--no-tests",
                       paste0("--output=", shQuote(out)), shQuote(tarball)), env = env)
log <- readLines(file.path(out, "FBC.Rcheck", "00check.log"))
res <- grep("^Status:", log, value = TRUE)
cat("\nR CMD check:", if (length(res)) res else "no status line", "\n")
bad <- grepl("ERROR|WARNING", res) || !length(res) || status != 0
if (bad) {
  cat(grep("(ERROR|WARNING)$", log, value = TRUE), sep = "\n")
  quit(status = 1)
}
