# Shared by test-factors.R and test-outputs.R.

# A two-output simulator sharing a rate t: a decay and a linear response.
two_outputs <- function(seed = 1, m = 40, noise = 0.05) {
  set.seed(seed)
  x <- runif(m); t <- runif(m, 0.5, 3)
  f1 <- function(x, t) 5 * exp(-t * x)
  f2 <- function(x, t) 2 * t * x
  sim <- rbind(data.frame(y = f1(x, t), x = x, out = "conc", t = t),
               data.frame(y = f2(x, t), x = x, out = "rate", t = t))
  xf <- seq(0.05, 0.95, length.out = 10)
  field <- rbind(data.frame(y = f1(xf, 1.7) + rnorm(10, 0, noise), x = xf, out = "conc"),
                 data.frame(y = f2(xf, 1.7) + rnorm(10, 0, noise), x = xf, out = "rate"))
  list(sim = sim, field = field, truth = 1.7)
}
