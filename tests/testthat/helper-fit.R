# A fit with the draws `Phi` (rows of chains `chain`), kept valid for the
# methods' gate (validate_fbc()): logPost, logLik and each chain's count of
# kept draws follow the draws (estimates are left as they were).
fit_with_draws <- function(fit, Phi, chain = rep(1L, nrow(Phi)), logPost = rep(0, nrow(Phi)),
                           logLik = logPost) {
  fit$Phi <- Phi
  fit$chain <- as.integer(chain)
  fit$logPost <- logPost
  fit$logLik <- logLik
  K <- max(chain)
  st <- rep(fit$state$chains, length.out = K)
  for (k in seq_len(K)) st[[k]]$kept <- sum(chain == k)
  fit$state$chains <- st
  fit
}

# A model (calibrate(..., fit = FALSE)) without kappa's jump move, the
# schedule of every fit before the jump became the default: the regression
# tests that reproduce earlier versions' draws to the bit fit this model.
no_jump <- function(model) {
  model$moves$jump <- NULL
  model
}
