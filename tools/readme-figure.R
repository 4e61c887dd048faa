# Draws the README's quick-start picture (man/figures/README-fits.png).
# Run from the package root with FBC installed: Rscript tools/readme-figure.R
library(FBC)
set.seed(2024)
fit <- calibrate(ballSim, ballField)
dir.create(file.path("man", "figures"), recursive = TRUE, showWarnings = FALSE)
ggplot2::ggsave(file.path("man", "figures", "README-fits.png"),
                plot(fit, type = "fits", xlab = "height h (m)"),
                width = 6, height = 3.5, dpi = 100)
