# Two tiers of tests. The default tier runs everywhere: the README's test
# command, R CMD check and CRAN. The slow tier (long chains, large m, design
# loops) runs when the environment variable FBC_SLOW is "true"; CI runs it
# after the default tier. A slow test starts with skip_if_not_slow().
slow_tier <- function() identical(tolower(Sys.getenv("FBC_SLOW")), "true")

skip_if_not_slow <- function() {
  testthat::skip_if_not(slow_tier(), "slow tier: set FBC_SLOW=true to run it")
}
