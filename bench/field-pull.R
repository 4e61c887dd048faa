# The diagnostic of an emulator bent by the field data (R/field_pull.R):
# the field data's pull on the emulator at kappa's draws, in runs-only
# predictive sds, on
#   - Tuo and Wu's example (2015, example 1): eta(x, u) = exp(x / 10) sin(x)
#     - sqrt(u^2 - u + 1) (sin(u x) + cos(u x)), x in [0, 2 pi], u in
#     [-1, 1], wrong for every u; the field the true process exp(x / 10)
#     sin(x) at 30 random inputs (noise sd 0.2), discrepancy = "none" (the
#     case the diagnostic is for): 30 runs on a maximin Latin hypercube
#     (lhs::maximinLHS, set.seed(2)), where the posterior has a second mode
#     near u = 0.5; the same design with 20 more space-filling runs
#     (lhs::augmentLHS); 80 maximin runs;
#   - the problems of bench/discrepancy.R (kinetics, Tuo and Wu with 40
#     runs and 15 field points, Plumlee's), each under "gp", "sgasp" and
#     "none", that benchmark's settings (its replicate 1): well-run
#     problems, on which the diagnostic must stay quiet.
# Columns: the problem, its runs and discrepancy model, the median pull
# and the share of the draws checked with a pull above 3, whether the
# message is given, kappa's median and 90% interval, and whether kappa's
# draws are multimodal (print()'s message).
#
#   Rscript bench/field-pull.R [--quick]
#
# --quick: Tuo and Wu's 30-run case and the discrepancy benchmark's
# problems under "none" only.
library(FBC)
quick <- "--quick" %in% commandArgs(trailingOnly = TRUE)

lhs <- function(m, k) vapply(seq_len(k), function(j) (sample(m) - stats::runif(m)) / m, numeric(m))
eta_tw <- function(x, th) exp(x / 10) * sin(x) - sqrt(th^2 - th + 1) * (sin(th * x) + cos(th * x))

row_of <- function(name, fit) {
  fp <- FBC:::field_pull(fit)
  msg <- convergence_messages(fit)
  k <- fit$Phi[, "kappa1"]
  q <- stats::quantile(k, c(0.05, 0.5, 0.95), names = FALSE)
  data.frame(problem = name, m = nrow(fit$model$data$Xs), model = fit$model$discrepancy,
             pull = stats::median(fp$pull), above3 = mean(fp$pull > 3),
             flagged = any(grepl("bend the emulator", msg)),
             median = q[2], lo90 = q[1], hi90 = q[3],
             multimodal = any(grepl("multimodal", msg)))
}

rows <- list()
show <- function(r) { rows[[length(rows) + 1]] <<- r; print(r, digits = 3, row.names = FALSE) }

# Tuo and Wu, 30 field points, the default run (until converged)
tw <- function(m, add = 0L) {
  set.seed(2)
  xf <- stats::runif(30, 0, 2 * pi)
  field <- data.frame(y = exp(xf / 10) * sin(xf) + stats::rnorm(30, 0, 0.2), x = xf)
  U <- lhs::maximinLHS(m, 2)
  if (add) U <- lhs::augmentLHS(U, add)
  sim <- data.frame(y = eta_tw(2 * pi * U[, 1], -1 + 2 * U[, 2]), x = 2 * pi * U[, 1],
                    t = -1 + 2 * U[, 2])
  suppressWarnings(calibrate(sim, field, discrepancy = "none"))
}
show(row_of("tuowu-30", tw(30)))
if (!quick) {
  show(row_of("tuowu-30 + 20", tw(30, 20L)))
  show(row_of("tuowu-30", tw(80)))
}

# bench/discrepancy.R's problems, its replicate 1
problems <- list(
  kinetics = list(zeta = function(x) 3.5 * exp(-1.7 * x) + 1.5, eta = function(x, th) 5 * exp(-th * x),
                  x = c(0, 3), theta = c(0, 3), xf = seq(0.11, 3.01, length.out = 10), reps = 3, sd = 0.2),
  tuowu = list(zeta = function(x) exp(x / 10) * sin(x), eta = eta_tw,
               x = c(0, 2 * pi), theta = c(-1, 1), xf = seq(0, 2 * pi, length.out = 15), reps = 1, sd = 0.2),
  plumlee = list(zeta = function(x) 4 * x + x * sin(5 * x), eta = function(x, th) th * x,
                 x = c(0, 1), theta = c(2, 6), xf = seq(0.05, 0.95, length.out = 12), reps = 1, sd = 0.1)
)
for (name in names(problems)) {
  pr <- problems[[name]]
  for (disc in if (quick) "none" else c("gp", "sgasp", "none")) {
    # (as bench/discrepancy.R's replicate 1: its runs drawn after set.seed(8),
    # the field and the fit continuing that stream)
    set.seed(8)
    u <- if (requireNamespace("lhs", quietly = TRUE)) lhs::maximinLHS(40, 2) else lhs(40, 2)
    x <- pr$x[1] + diff(pr$x) * u[, 1]
    th <- pr$theta[1] + diff(pr$theta) * u[, 2]
    sim <- cbind(y = pr$eta(x, th), x = x, t = th)
    xr <- rep(pr$xf, each = pr$reps)
    fld <- cbind(y = pr$zeta(xr) + stats::rnorm(length(xr), 0, pr$sd), x = xr)
    fit <- suppressWarnings(calibrate(sim, fld, nMCMC = 3000, nBurn = 1000, nChains = 2,
                                      kernelS = "matern52", kernelB = "matern52", discrepancy = disc))
    show(row_of(name, fit))
  }
}
cat("\n")
print(do.call(rbind, rows), digits = 3, row.names = FALSE)
