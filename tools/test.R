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
if (skipped > 0) cat(sprintf("\n%d skipped", skipped))
# the failures again, last, so that a log's tail names them
for (t in res) {
  for (r in t$results) {
    if (inherits(r, c("expectation_failure", "expectation_error"))) {
      msg <- strsplit(conditionMessage(r), "\n")[[1]]
      cat(sprintf("\nFailed: %s: %s\n  %s", t$file, t$test,
                  paste(utils::head(msg, 6), collapse = "\n  ")))
    }
  }
}
cat(sprintf("\n%d passed, %d failed\n", passed, failed))
quit(status = if (failed > 0 || passed == 0) 1 else 0)
