# The main job: calibrate the ball-drop simulator against the field data,
# print the posterior summary and save the density, trace and fits plots.
# Run from the package root: Rscript tools/example.R
source("tools/deps.R")  # installs what is missing, then FBC from this checkout
library(FBC)

set.seed(2024)
fit <- calibrate(ballSim, ballField)
cat(sprintf("Calibrated in %.1f s; %d draws kept.\n\nPosterior summary:\n",
            fit$settings$time, nrow(fit$Phi)))
print(summary(fit))
msgs <- convergence_messages(fit)
cat("\nConvergence checks (R-hat < 1.01, bulk ESS >= 400, bounds):\n")
cat(if (length(msgs)) paste("!", msgs) else "all passed", sep = "\n")
cat("\nCalibrated prediction of the drop time at h = 2.2 and 2.4 m:\n")
pred <- predict(fit, c(2.2, 2.4))
print(data.frame(h = c(2.2, 2.4), pred = pred$pred, se = pred$se,
                 lower = pred$lower, upper = pred$upper), digits = 3)

dir.create("out", showWarnings = FALSE)
plots <- list(
  density = plot(fit, parameter = "kappa", type = "density"),
  trace = plot(fit, parameter = "kappa", type = "trace"),
  fits = plot(fit, type = "fits", xlab = "height h (m)")
)
files <- file.path("out", paste0("ball-", names(plots), ".png"))
for (i in seq_along(plots)) {
  ggplot2::ggsave(files[i], plots[[i]], width = 6, height = 4, dpi = 100)
}
cat("\nPlots written to:\n", paste0("  ", normalizePath(files), "\n"), sep = "")
