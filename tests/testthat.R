library(testthat)
library(FBC)

test_check("FBC")
