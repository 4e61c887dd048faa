# Installs what FBC needs and is missing, then installs FBC itself from this
# checkout. Debian's prebuilt r-cran-* packages are used when we are root on
# a Debian machine (quick, and built for this R); CRAN otherwise.
needed <- c("Rcpp", "RcppArmadillo", "cli", "ggplot2", "lhs", "testthat", "knitr",
            "rmarkdown", "coda", "posterior", "future", "progressr",
            # Suggests the tests use: kill-and-resume in a child process,
            # the batchtools backend, PSIS-LOO (loo.fbc) and bayesplot's
            # plots (all skip when missing, but CI runs them)
            "callr", "future.batchtools", "loo", "bayesplot",
            # the generics posterior_predict(), log_lik(), ... (Imports)
            "rstantools")
have <- function(p) requireNamespace(p, quietly = TRUE)
missing <- needed[!vapply(needed, have, logical(1))]
if (length(missing)) {
  message("Installing: ", paste(missing, collapse = ", "))
  apt <- Sys.which("apt-get")
  is_root <- identical(Sys.info()[["effective_user"]], "root")
  if (nzchar(apt) && is_root) {
    debs <- paste0("r-cran-", tolower(missing))
    system2(apt, c("update", "-qq"), stdout = FALSE)
    status <- system2(apt, c("install", "-y", "-qq", debs),
                      env = "DEBIAN_FRONTEND=noninteractive", stdout = FALSE)
    if (status != 0) message("apt-get could not install every package; trying CRAN.")
  }
  missing <- needed[!vapply(needed, have, logical(1))]
  if (length(missing)) {
    lib <- .libPaths()[1]
    utils::install.packages(missing, lib = lib, quiet = TRUE)
  }
  missing <- needed[!vapply(needed, have, logical(1))]
  if (length(missing)) stop("Could not install: ", paste(missing, collapse = ", "))
}
# Install FBC from this checkout (--preclean: never link stale objects).
status <- system2(file.path(R.home("bin"), "R"),
                  c("CMD", "INSTALL", "--preclean", "--no-multiarch", "."))
if (status != 0) stop("R CMD INSTALL of FBC failed")
