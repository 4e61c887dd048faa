# The test command: installs what is missing and FBC itself, runs the test
# suite and ends with the line "N passed, N failed" (exit status 1 on any
# failure). Run from the package root: Rscript tools/test.R
source("tools/deps.R")
Sys.setenv(NOT_CRAN = "true") # run the snapshot tests too
res <- testthat::test_dir("tests/testthat", package = "FBC", load_package = "installed",
                          reporter = testthat::ProgressReporter$new(show_praise = FALSE),
                          stop_on_failure = FALSE, stop_on_warning = FALSE)
df <- as.data.frame(res)
passed <- sum(df$passed)
failed <- sum(df$failed) + sum(df$error)
skipped <- sum(df$skipped)
cat(sprintf("\n%d passed, %d failed, %d skipped\n", passed, failed, skipped))
quit(status = if (failed > 0 || passed == 0) 1 else 0)
