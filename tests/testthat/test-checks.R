test_that("a value of the wrong type is reported as that type, not as a wrong value", {
  expect_snapshot(error = TRUE, {
    calibrate(ballSim, ballField, nMCMC = "300")
    calibrate(ballSim, ballField, nChains = c(2, 4))
    calibrate(ballSim, ballField, showProgress = "yes")
    calibrate(ballSim, ballField, kernelB = 2)
    calibrate(ballSim, ballField, checkpoint = 1)
  })
  # a wrong number is still shown as the number
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, nMCMC = 10.5))
})

test_that("format_value() names the type where it may be what is wrong", {
  expect_identical(FBC:::format_value("300"), "the string \"300\"")
  expect_identical(FBC:::format_value(300), "300")
  expect_identical(FBC:::format_value(0.5, typed = TRUE), "the number 0.5")
  expect_identical(FBC:::format_value(c(2, 4)), "a numeric vector of length 2")
  expect_identical(FBC:::format_value(letters[1:3]), "a character vector of length 3")
  expect_identical(FBC:::format_value(list(1)), "a list of length 1")
  expect_identical(FBC:::format_value(factor("a")), "a <factor> object of length 1")
  expect_identical(FBC:::format_value(NA_character_), "NA")
  expect_identical(FBC:::format_value(NULL), "NULL")
  expect_identical(FBC:::format_value(TRUE), "TRUE")
  expect_identical(FBC:::format_choice("MAP"), "\"MAP\"")
  expect_identical(FBC:::format_choice(2L), "the number 2")
})

test_that("blockSim maps onto sampler, and is refused when an explicit sampler disagrees", {
  expect_warning(s <- FBC:::check_sampler(c("blocks", "single"), blockSim = FALSE), "deprecated")
  expect_identical(s, "single")
  expect_warning(s <- FBC:::check_sampler("single", blockSim = FALSE), "deprecated")
  expect_identical(s, "single")
  expect_identical(FBC:::check_sampler("single"), "single")
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, sampler = "single", blockSim = TRUE))
})

test_that("field data without an experimental input (p = 0) are refused naming the need", {
  # a simulator whose only input is a calibration input, observed as scalars
  sim <- data.frame(y = sin(1:20), t = 1:20)
  expect_snapshot(error = TRUE, calibrate(sim, data.frame(y = c(0.1, 0.2))))
  expect_snapshot(error = TRUE, calibrate(as.matrix(sim), matrix(c(0.1, 0.2), ncol = 1)))
})
