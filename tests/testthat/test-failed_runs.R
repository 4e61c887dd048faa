# Failed simulator runs: set aside with one message, the posterior that of
# the successful runs, and a classifier of where the simulator fails.

spotweld_raw <- function() {
  s <- utils::read.table(test_path("../../data-raw/spotweld/sw_sim.txt"), header = TRUE)
  f <- utils::read.table(test_path("../../data-raw/spotweld/sw_field.txt"), header = TRUE)
  list(sim = data.frame(diameter = s$NuggetDiam, gauge = s$Gauge, load = s$Load,
                        current = s$Current, tau = s$t),
       field = data.frame(diameter = f$Field, gauge = f$Gauge, load = f$Load,
                          current = f$Current))
}

test_that("failed runs are set aside with one message and kept in the model", {
  skip_if_not(file.exists(test_path("../../data-raw/spotweld/sw_sim.txt")), "raw data not shipped")
  sw <- spotweld_raw()
  expect_snapshot(model <- calibrate(sw$sim, sw$field, fit = FALSE))
  failed <- model$design$failed
  expect_identical(failed$rows, which(is.na(sw$sim$diameter)))
  expect_equal(length(failed$rows), 17L)
  expect_equal(failed$m, 52L)
  expect_equal(model$dims$m, 35L)
  # the model calibrates on exactly the successful runs
  clean <- calibrate(sw$sim[!is.na(sw$sim$diameter), ], sw$field, fit = FALSE)
  expect_identical(model$data, clean$data)
  expect_identical(model$spec$priors, clean$spec$priors)
  expect_identical(failed$runs, sw$sim[failed$rows, -1])
})

test_that("the posterior with failed runs is the posterior of the successful runs, draw for draw", {
  s <- ballSim
  s[c(3, 10, 20), 1] <- c(NA, NaN, Inf)
  set.seed(11)
  a <- suppressMessages(calibrate(s, ballField, nMCMC = 200, nBurn = 100, nChains = 1,
                                  showProgress = FALSE))
  set.seed(11)
  b <- calibrate(ballSim[-c(3, 10, 20), ], ballField, nMCMC = 200, nBurn = 100, nChains = 1,
                 showProgress = FALSE)
  expect_identical(a$Phi, b$Phi)
  expect_identical(a$model$design$failed$rows, c(3L, 10L, 20L))
  expect_identical(s[c(3, 10, 20), 1], c(NA, NaN, Inf)) # the user's data untouched
  # print() says how many were set aside; without failed runs, nothing
  said <- utils::capture.output(print(a))
  expect_length(grep(sprintf("failed runs: 3 of %d set aside", nrow(ballSim)), said, fixed = TRUE), 1L)
  expect_length(grep("failed runs", utils::capture.output(print(b))), 0L)
})

test_that("failedRuns = \"error\" refuses failed runs, and bad inputs of failed runs are refused", {
  s <- ballSim
  s[5, 1] <- NA
  expect_snapshot(calibrate(s, ballField, failedRuns = "error", fit = FALSE), error = TRUE)
  expect_snapshot(calibrate(s, ballField, failedRuns = "drop", fit = FALSE), error = TRUE)
  s[5, 2] <- NA
  expect_snapshot(calibrate(s, ballField, fit = FALSE), error = TRUE)
  s <- ballSim[1:4, ]
  s[2:4, 1] <- NA
  expect_snapshot(calibrate(s, ballField, fit = FALSE), error = TRUE)
})

test_that("the failure classifier's Laplace mode solves its fixed-point equation", {
  set.seed(3)
  Z <- matrix(stats::runif(60), 30, 2)
  y <- as.numeric(rowSums((Z - 0.5)^2) < 0.1)
  ell <- c(0.3, 0.4)
  s2 <- 2
  md <- laplace_mode(Z, y, ell, s2)
  K <- failure_kernel(Z, Z, ell, s2)
  # at the mode of p(f | y): f = K (y - logistic(f))
  expect_equal(md$f, drop(K %*% (y - stats::plogis(md$f))), tolerance = 1e-6)
  # the Laplace evidence against its definition with plain matrices
  W <- diag(stats::plogis(md$f) * (1 - stats::plogis(md$f)))
  ref <- -0.5 * sum(md$f * solve(K, md$f)) + sum(y * md$f - log1p(exp(md$f))) -
    0.5 * determinant(diag(30) + K %*% W)$modulus[[1]]
  expect_equal(md$logZ, ref, tolerance = 1e-6)
})

test_that("the Laplace evidence's gradient is its difference quotient", {
  set.seed(3)
  Z <- matrix(stats::runif(80), 40, 2)
  y <- as.numeric(rowSums((Z - 0.5)^2) < 0.1)
  par <- c(log(0.2), log(0.35), log(1.5))
  ev <- laplace_evidence(Z, y, exp(par[1:2]), exp(par[3]))
  h <- 1e-5
  num <- vapply(1:3, function(j) {
    e <- replace(numeric(3), j, h)
    up <- laplace_mode(Z, y, exp(par[1:2] + e[1:2]), exp(par[3] + e[3]), tol = 1e-13)$logZ
    dn <- laplace_mode(Z, y, exp(par[1:2] - e[1:2]), exp(par[3] - e[3]), tol = 1e-13)$logZ
    (up - dn) / (2 * h)
  }, numeric(1))
  expect_equal(ev$grad, num, tolerance = 1e-5)
  expect_equal(ev$logZ, laplace_mode(Z, y, exp(par[1:2]), exp(par[3]))$logZ)
})

test_that("the failure probability finds a known failure region", {
  set.seed(4)
  m <- 120
  X <- cbind(x = stats::runif(m), t = stats::runif(m, 10, 20))
  inside <- (X[, "x"] - 0.5)^2 + ((X[, "t"] - 15) / 10)^2 < 0.25^2
  y <- ifelse(inside, NA, sin(3 * X[, "x"]) + X[, "t"] / 10)
  sim <- data.frame(y = y, x = X[, "x"], t = X[, "t"])
  field <- data.frame(y = sin(3 * (1:8) / 9) + 1.5, x = (1:8) / 9)
  model <- suppressMessages(calibrate(sim, field, fit = FALSE))
  cl <- model$design$failed$classifier
  centre <- failure_probability(cl, cbind(x = 0.5, t = 15))
  corners <- failure_probability(cl, cbind(x = c(0.05, 0.95, 0.05, 0.95),
                                           t = c(10.5, 10.5, 19.5, 19.5)))
  expect_gt(centre, 0.8)
  expect_true(all(corners < 0.2))
  # on a grid over the box, p > 1/2 is the disc but for a rim
  g <- as.matrix(expand.grid(x = seq(0.025, 0.975, 0.05), t = seq(10.25, 19.75, 0.5)))
  truth <- (g[, "x"] - 0.5)^2 + ((g[, "t"] - 15) / 10)^2 < 0.25^2
  expect_gt(mean((failure_probability(cl, g) > 0.5) == truth), 0.9)
  # ranks the runs: failed runs above the successful ones on average
  p <- failure_probability(cl, X)
  expect_gt(mean(p[inside]), mean(p[!inside]) + 0.5)
  # a deterministic code fails again where it failed: the classifier
  # interpolates its runs (the latent's mode at a large scale)
  expect_true(all(p[inside] > 0.8) && all(p[!inside] < 0.2))
  expect_gt(cl$s2, 100)
})

test_that("the failure classifier is fitted when a probability is first asked for, once", {
  set.seed(4)
  X <- cbind(x = stats::runif(60), t = stats::runif(60, 10, 20))
  inside <- (X[, "x"] - 0.5)^2 + ((X[, "t"] - 15) / 10)^2 < 0.25^2
  sim <- data.frame(y = ifelse(inside, NA, sin(3 * X[, "x"]) + X[, "t"] / 10), x = X[, "x"],
                    t = X[, "t"])
  field <- data.frame(y = sin(3 * (1:8) / 9) + 1.5, x = (1:8) / 9)
  model <- suppressMessages(calibrate(sim, field, fit = FALSE))
  cl <- model$design$failed$classifier
  expect_false(cl$fitted) # calibrate() does not pay for it
  expect_null(cl$ell)
  p1 <- failure_probability(cl, X)
  expect_true(cl$fitted)
  ell <- cl$ell
  # a second call reuses the fit (the same plug-in values, the same probabilities)
  expect_identical(failure_probability(cl, X), p1)
  expect_identical(cl$ell, ell)
  # against a classifier built and fitted afresh on the same runs
  expect_identical(failure_probability(failure_classifier(sim[, -1], inside), X), p1)
  # a fit saved when the classifier was fitted by calibrate() holds it as a
  # plain list of the fitted values (no `keep`, no `fitted`): used as it is
  old <- as.list.environment(cl)
  old[c("keep", "fitted", "subsample")] <- NULL
  expect_identical(failure_probability(old, X), p1)
  # above max_runs the subsample is drawn when the classifier is built: set.seed() reproduces
  # it whether or not it is ever fitted
  set.seed(9)
  a <- failure_classifier(sim[, -1], inside, max_runs = 30L)
  set.seed(9)
  b <- failure_classifier(sim[, -1], inside, max_runs = 30L)
  expect_identical(a$keep, b$keep)
  expect_length(a$keep, 30L)
  expect_true(all(which(inside) %in% a$keep))
  expect_true(a$subsample)
})

test_that("predict(type = \"failure\") takes the inputs by name or position, and refuses clearly", {
  s <- ballSim
  s[c(3, 10, 20), 1] <- NA
  set.seed(5)
  fit <- suppressMessages(calibrate(s, ballField, nMCMC = 100, nBurn = 50, nChains = 1,
                                    showProgress = FALSE))
  nd <- data.frame(g = c(9, 10), h = c(5, 50))
  byName <- predict(fit, nd, type = "failure")
  expect_length(byName, 2L)
  expect_true(all(byName > 0 & byName < 1))
  expect_identical(predict(fit, unname(as.matrix(nd[, c("h", "g")])), type = "failure"), byName)
  expect_length(predict(fit, type = "failure"), 100L)
  expect_snapshot(predict(fit, data.frame(h = 1), type = "failure"), error = TRUE)
  set.seed(5)
  clean <- calibrate(ballSim, ballField, nMCMC = 100, nBurn = 50, nChains = 1, showProgress = FALSE)
  expect_snapshot(predict(clean, nd, type = "failure"), error = TRUE)
})

test_that("update(fit, sim = ) sets aside the failed runs among the new ones", {
  s <- ballSim[41:50, ]
  s[c(2, 7), 1] <- NA
  set.seed(6)
  fit <- suppressWarnings(calibrate(ballSim[1:40, ], ballField, nMCMC = 100, nBurn = 50,
                                    nChains = 1, showProgress = FALSE))
  expect_message(fit2 <- suppressWarnings(update(fit, sim = s)), "2 of the 50 simulator runs failed")
  expect_equal(fit2$model$dims$m, 48L)
  expect_identical(fit2$model$design$failed$rows, c(42L, 47L))
})
