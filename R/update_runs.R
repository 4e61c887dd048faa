# Design of new simulator runs: adding runs to a fit with a warm
# start (update_runs()), choosing where to run next from the joint
# posterior (propose_runs(), R/propose_runs.R) and the loop for a
# simulator given as an R function (design_loop(), R/design_loop.R).

# ------------------------------------------------------- adding runs ----

#' Add simulator runs to a calibration
#'
#' `update(fit, sim = more_runs)` rebuilds the model on all runs (the old
#' and the new, exactly as `calibrate(rbind(old, new), field, ...)` with the
#' fit's model arguments would: the same scaling, priors and algebra
#' choice) and draws its posterior in one of two ways; the fit says which
#' (`settings$reweight`, and a line of `print()`).
#'
#' **Reweighted** (tried first when the run length is the stop rule's, the
#' default): the old fit's draws, carried to the new scaling (below), are
#' weighed by the new posterior over the old one. The weight
#' \eqn{p_{new}(T\phi \mid \textrm{all runs}) |dT/d\phi| / p_{old}(\phi \mid
#' \textrm{old runs})} is exact up to a constant (the new model's prior and
#' likelihood on all runs, one likelihood per draw: every draw, or of
#' N >= 4000 draws every `N %/% 2000`-th), so
#' the weighted draws are importance draws of the new posterior, not an
#' approximation of it. Each chain is resampled in order by the weights,
#' and the result is used when it meets the stop rule: R-hat of the
#' resampled chains, and a bulk ESS counted as the smaller of the resampled
#' chains' and the old bulk ESS times the weights' Kish share
#' (\eqn{(\sum w)^2 / (N \sum w^2)}); the fit's `estimates$ess` are these
#' counts. When that count is short of the rule's but at least a quarter
#' of it, the resampled chains go on from their last draws with the old
#' adapted proposals until the old and new draws meet the rule
#' (resample-move; `settings$reweight$topUp` sweeps a chain), for at most
#' about 3000 sweeps a chain (a fresh fit's length). The proposals were
#' adapted at the last refit, and as runs narrow the posterior they go
#' stale: with three calibration inputs continuations ran up to 50,800
#' sweeps where a fresh fit took 3550. So when a move accepts under a
#' quarter of its adaptation's target in the continuation's first 500
#' sweeps (`settings$reweight$stale` names them), or the rule is not met by
#' the cap, or the reweighted draws hold under a quarter of the rule's
#' effective draws, the model is refitted (from the continuation's last
#' states when there was one). On design loops most steps are reweighted or
#' continued, at a fraction of a fresh fit's cost, with kappa posteriors as
#' close to fresh fits' as refits are (measured: `vignette("design", package
#' = "FBC")`).
#'
#' **Refitted** otherwise (and with `reweight = FALSE`, `nMCMC` or `nBurn`
#' given): from the chains' last states (a warm start) with a fresh
#' adaptive warm-up (or `nBurn` sweeps). The posterior is that of a fresh
#' fit on all runs (tested against the grid posterior). A warm refit costs
#' about what a fresh fit does: the warm start shortens the warm-up a
#' little, but both need the same sampling for the stop rule's effective
#' draws of the new posterior.
#'
#' The draws and last states are carried to the new model's scaling (the
#' map \eqn{T}): kappa in its own units, each length-scale `theta` by the
#' change of its input's range (to the power `alpha` for the power
#' exponential, 2 otherwise), the variances and `muB` by the change of the
#' response's mean and sd (with several outputs by the first output's: the
#' weights, or the chains' warm-up, correct the rest). Fixed parameters
#' take the new model's values.
#'
#' @param fit An `fbc` object.
#' @param sim The new runs, with the columns of the fit's `sim` (a data
#'   frame with its names, or a matrix with its columns in its order).
#' @param nMCMC,converge The refit's run length, as in [calibrate()]: by
#'   default until converged ([until_converged()]).
#' @param nBurn Warm-up sweeps before draws are kept. `NULL` (the default)
#'   runs the adaptive warm-up of [calibrate()] from the chains' last
#'   states, so it ends when the proposals have settled on the new
#'   posterior.
#' @param showProgress As in [calibrate()].
#' @param reweight Try the old draws reweighted first (`TRUE`, the default;
#'   only when `nMCMC` and `nBurn` are `NULL`), or always refit (`FALSE`).
#' @return A new `fbc` object of the model on all runs (its draws are the
#'   reweighted old draws or the refit's only). `settings$warmStart` is
#'   `TRUE`; `settings$reweight` (`NULL` when not tried) is a list: `used`
#'   (`FALSE` when refitted after all),
#'   `runs` (the old fit's), `draws` (weighed), `kish` (the weights' Kish
#'   share), `rhat` and `ess` (the largest R-hat and smallest bulk ESS of
#'   the resampled draws), `topUp` (sweeps a chain added after them), `stale`
#'   (the moves found stale in the continuation, if any). A
#'   reweighted fit is continued by `update(fit, nMCMC = )` from its
#'   resampled draws with the old adapted proposals (it warns when they
#'   are stale).
#' @seealso [propose_runs()], [design_loop()]
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim[1:40, ], ballField, nChains = 2)
#' fit2 <- update(fit, sim = ballSim[41:50, ])
#' fit2$model$dims$m
update_runs <- function(fit, sim, nMCMC = NULL, nBurn = NULL, converge = NULL,
                        showProgress = NULL, reweight = TRUE) {
  fit <- check_fbc(fit, "fit")
  old <- fit$model
  args <- old$options$args
  if (!is.null(old$simulator)) {
    cli::cli_abort(c(
      "This fit calibrates a simulator function, which has no runs to add to.",
      i = "{.fn propose_runs} and {.fn update_runs} work on fits of simulator runs; {.fn design_loop} builds such a fit from a function."
    ))
  }
  if (is.null(args)) {
    cli::cli_abort(c(
      "This fit does not hold the arguments its model was built from (it was made by an earlier FBC), so runs cannot be added to it.",
      i = "Fit it again with {.fn calibrate} on all runs."
    ))
  }
  t0 <- proc.time()[["elapsed"]]
  allSim <- bind_runs(args$sim, sim)
  rest <- args[setdiff(names(args), "sim")]
  # (the call is set afterwards: do.call() would evaluate a call given to it)
  model <- muffle_wide_outputs(do.call(build_model, c(list(sim = allSim), rest,
                                                     list(call = environment()))))
  model$call <- fit$call
  model$spec$model$threads <- old$spec$model$threads
  if (!identical(model$spec$vars, old$spec$vars)) {
    cli::cli_abort(c(
      "With the new runs the model has other parameters ({format_names(setdiff(union(model$spec$vars, old$spec$vars), intersect(model$spec$vars, old$spec$vars)))}), so the chains cannot go on from where they stopped.",
      i = "Fit it again with {.fn calibrate} on all runs."
    ))
  }
  states <- fit$state$chains
  run <- check_run(nMCMC, nBurn, fit$settings$thinning, length(states), converge, showProgress,
                   NULL, 60)
  reweight <- check_flag(reweight, "reweight")
  tried <- NULL
  from <- old
  if (reweight && is.null(nMCMC) && is.null(nBurn) && !is.null(run$converge)) {
    rw <- reweight_runs(fit, model, run$converge)
    if (rw$info$used) return(rw$fit)
    tried <- rw$info
    if (!is.null(rw$fit)) {
      up <- top_up(rw$fit, run$converge, run$showProgress)
      if (isTRUE(up$settings$converge$converged) || isTRUE(up$state$interrupted)) return(up)
      # the continuation did not meet the rule (its proposals stale after
      # the first stretch, or fbc_topup_max sweeps run): a refit from its
      # last states (draws of the new posterior), with fresh proposals and
      # warm-up
      tried <- up$settings$reweight
      tried$used <- FALSE
      states <- up$state$chains
      from <- model
    }
  }
  d <- length(model$spec$vars)
  starts <- lapply(states, function(st) chain_start(warm_state(st$sampler, from, model), d, 0L))
  assemble <- function(results, target) {
    results <- check_chain_results(results, max(target))
    settings <- list(nMCMC = max(target), nBurn = run$nBurn, thinning = run$thinning,
                     nChains = length(results), nugget = fbc_nugget,
                     time = proc.time()[["elapsed"]] - t0, checkpoint = NULL, warmStart = TRUE,
                     reweight = tried)
    new_fbc_chains(results, model, fit$call, settings = settings)
  }
  run_rounds(starts, chain_seeds(length(starts)), rep(run$nMCMC, length(starts)), run$converge,
             assemble, nBurn = run$nBurn, thinning = run$thinning,
             showProgress = run$showProgress, dat = model$data, spec = model$spec,
             moves = model$moves)
}

# ------------------------------------------------ reweighting draws ----

# The old fit's N draws are reweighted every floor(N / this)-th (each
# chain thinned evenly; all of them below twice this, 2000 to 4000 of them
# from there): the draws' autocorrelation leaves their effective number nearly
# whole, and each costs one likelihood from scratch.
fbc_reweight_draws <- 2000L
# Below this share of the stop rule's effective draws (the old bulk ESS
# times the weights' Kish share) the reweighted draws are not continued
# (top_up()) but refitted.
fbc_reweight_floor <- 0.25
# The most sweeps a chain continues reweighted draws (top_up()) before
# update_runs() refits instead: about a fresh default fit's length (warm-up
# and sampling: 1650-3550 sweeps on the design benchmark's problems). The
# continuation keeps the proposals adapted at the last refit, which may be
# several reweighted steps back; as runs are added the posterior narrows and
# they go stale. With three calibration inputs (bench/design.R
# --problem=three, 14 replicates) 13 of 420 continuations ran 20,000-50,800
# sweeps (up to 165 CPU s; the parameters' block accepted 3% against a
# fresh fit's 17%), where a fresh fit on the same runs took 6 CPU s.
fbc_topup_max <- 3000L

# update_runs()'s first try: the old fit's draws as draws of `model` (the
# model on all runs). Each draw phi is carried to the new scaling, phi' =
# T(phi) (warm_phi()), and weighed by the importance weight of the old
# posterior as a proposal for the new one,
#   w = p_new(phi' | all runs) |dT/dphi| / p_old(phi | old runs),
# exact up to a constant: log p_new is the new model's log prior plus its
# log-likelihood on all runs (.fbc_loglik_draws_c(), its own algebra),
# log p_old the fit's logPost (log prior plus log-likelihood, the same
# units), and log |dT/dphi| varies only through theta_k r_k^alpha_k (+
# alpha_k log r_k; the other maps scale by constants). Each chain is then
# resampled systematically in its draws' order by their weights (each
# chain an importance sample of its own, as each chain of the old fit is a
# sample of the old posterior), so it keeps its length and its R-hat and
# bulk ESS see the repeated draws; the bulk ESS is capped by the old one
# times the weights' Kish share ((sum w)^2 / (N sum w^2)). Returns
# list(fit, info = list(used, runs (the old fit's), draws, kish, rhat, ess,
# topUp)): `fit` the resampled draws (info$used: they meet the stop rule
# `rule`), or NULL when the capped ESS is below fbc_reweight_floor of the
# rule's (no resampling: the caller refits).
reweight_runs <- function(fit, model, rule) {
  t0 <- proc.time()[["elapsed"]]
  old <- fit$model
  chains <- sort(unique(fit$chain))
  N <- length(fit$chain)
  by <- max(1L, N %/% fbc_reweight_draws)
  rows <- unlist(lapply(chains, function(k) {
    i <- which(fit$chain == k)
    i[rev(seq(length(i), 1L, by = -by))]  # evenly, the last draw kept
  }))
  chain <- fit$chain[rows]
  lw <- reweight_log_weights(fit, model, rows)
  phiNew <- attr(lw, "phi")
  ll <- attr(lw, "logLik")
  lp <- attr(lw, "logPrior")
  info <- list(used = FALSE, runs = old$dims$m, draws = length(rows), kish = 0, rhat = NA_real_,
               ess = 0)
  w <- if (any(is.finite(lw))) exp(lw - max(lw)) else rep(0, length(lw))
  perChain <- vapply(chains, function(k) sum(w[chain == k]), numeric(1))
  if (!all(perChain > 0)) return(list(fit = NULL, info = info))
  info$kish <- sum(w)^2 / sum(w^2) / length(w)
  bound <- fit$estimates$ess * info$kish
  info$ess <- min(bound, na.rm = TRUE)
  # too few for a top-up to pay: no resampling (the caller refits)
  if (!(info$ess >= fbc_reweight_floor * rule$ess)) return(list(fit = NULL, info = info))
  results <- lapply(seq_along(chains), function(c) {
    i <- which(chain == chains[c])
    cw <- cumsum(w[i]) / perChain[c]
    pick <- i[pmin(findInterval((seq_along(i) - stats::runif(1)) / length(i), cw,
                                left.open = TRUE) + 1L, length(i))]
    st <- fit$state$chains[[c]]
    state <- st$sampler
    state$phi <- phiNew[pick[length(pick)], ]
    list(draws = phiNew[pick, , drop = FALSE], logPost = ll[pick] + lp[pick], logLik = ll[pick],
         kept = length(pick), done = st$done, nPost = st$nPost, interrupted = FALSE,
         state = state)
  })
  s <- fit$settings
  cv <- rule
  cv[c("converged", "sweeps", "checks", "reweighted")] <- list(TRUE, NA_integer_, 0L, TRUE)
  s[c("checkpoint", "warmStart", "converge")] <- list(NULL, TRUE, cv)
  # the chains go on (top_up(), update()) with the walk: an independence
  # proposal (sampler_moves()) was fitted to the old posterior's warm-up
  model$moves$independent <- integer()
  out <- new_fbc_chains(results, model, fit$call, s)
  est <- out$estimates
  ess <- pmin(est$ess, bound)
  ok <- !is.na(est$rhat) & !is.na(ess)
  info$rhat <- if (any(ok)) max(est$rhat[ok]) else NA_real_
  info$ess <- if (any(ok)) min(ess[ok]) else 0
  info$used <- any(ok) && all(est$rhat[ok] < rule$rhat) && all(ess[ok] >= rule$ess)
  out$estimates$ess <- ess
  info$topUp <- 0L
  out$settings$reweight <- info
  out$settings$time <- proc.time()[["elapsed"]] - t0
  list(fit = out, info = info)
}

# The log importance weights of the old fit's draws `rows` as draws of
# `model` (up to a constant; reweight_runs()), with attributes phi (the
# draws on the new scaling), logLik and logPrior (the new model's).
reweight_log_weights <- function(fit, model, rows) {
  old <- fit$model
  phiOld <- sampler_draws(fit, rows)
  phiNew <- warm_phi(phiOld, old, model)
  dat <- model$data
  ll <- drop(.fbc_loglik_draws_c(dat$Xf, dat$yf, dat$Xs, dat$ys, phiNew, fbc_nugget,
                                  model$spec$model))
  tab <- model$spec$table
  free <- which(tab$family != prior_families[["fixed"]])
  lp <- Reduce(`+`, lapply(free, function(j) log_prior_row(tab, j, phiNew[, j])), 0)
  lw <- ll + lp + reweight_log_jacobian(phiOld, old, model) - fit$logPost[rows]
  lw[is.na(lw)] <- -Inf
  structure(lw, phi = phiNew, logLik = ll, logPrior = lp)
}

# The reweighted draws `fit` (reweight_runs()) short of the stop rule `rule`
# continued as chains, from the last resampled draw with the old adapted
# proposals, until the old and new draws meet it (update(fit, converge =
# rule)), for at most fbc_topup_max sweeps a chain: resample-move.
# settings$reweight$topUp counts the sweeps a chain added,
# settings$converge says whether the rule was met (update_runs() refits
# when not).
top_up <- function(fit, rule, showProgress) {
  info <- fit$settings$reweight
  before <- fit$settings$nMCMC
  rule$first <- NULL  # (calibrate()'s first check, counted from the warm-up's end)
  # the rule's ceiling counts from here: the chains carry the sweeps of
  # every fit since the last refit
  start <- chain_sweeps(fit)
  cap <- as.integer(min(.Machine$integer.max, start + min(rule$maxMCMC, fbc_topup_max)))
  # update()'s first stretch (fbc_first_check sweeps), then checks every
  # as many: not by the default schedule (steps of up to half the retained
  # sweeps), since the chains' sweeps since the last refit can be many (a chain at 50,000 took 25,650
  # more at its second check). A first stretch sized to the shortfall at
  # the old chains' ESS rate was measured dearer (sinusoid loop, 10
  # replicates: the loop's fits 0.51 of fresh fits' CPU against 0.35): the
  # fits it ends just meet the rule, so the next steps fall short again
  rule$every <- fbc_first_check
  # the first stretch, every chain fbc_first_check sweeps, then the rule's
  # first check and the stretch's acceptance: stale proposals (a move
  # accepting under a quarter of its adaptation's target) end the
  # continuation there, and update_runs() refits
  out <- update.fbc(fit, nMCMC = min(fbc_first_check, cap - start), showProgress = showProgress)
  met <- meets_rule(out, rule)
  out$settings$converge <- c(unclass(rule), list(converged = met, checks = 1L,
                                                 sweeps = chain_sweeps(out)))
  info$stale <- stale_moves(fit, out)
  if (!met && !isTRUE(out$state$interrupted) && !length(info$stale) && chain_sweeps(out) < cap) {
    rule$maxMCMC <- cap
    out <- update.fbc(out, converge = rule, showProgress = showProgress)
  }
  info$topUp <- as.integer(out$settings$nMCMC - before)
  info$used <- TRUE
  out$settings$converge$reweighted <- TRUE
  out$settings[c("reweight", "warmStart")] <- list(info, TRUE)
  out
}

# The adapted moves (walks, blocks, single sites, scale) whose acceptance
# over the sweeps `after` ran beyond `before` (the same chains, continued),
# pooled over the chains, is under a quarter of the adaptation's target
# (0.44; 0.234 for a block of several parameters): their frozen steps no
# longer suit the posterior. Their names.
stale_moves <- function(before, after) {
  mb <- pool_moves(lapply(before$state$chains, function(s) s$sampler$moves))
  ma <- pool_moves(lapply(after$state$chains, function(s) s$sampler$moves))
  tries <- ma$tries - mb$tries
  rate <- (ma$accepted - mb$accepted) / tries
  size <- lengths(strsplit(ma$params, ",", fixed = TRUE))
  target <- ifelse(ma$kind == "joint" & size > 1L, 0.234, 0.44)
  low <- ma$kind %in% c("walk", "joint", "single", "scale") & tries > 0 & rate < target / 4
  ma$name[low]
}

# log |dT/dphi| of warm_phi() up to a constant, per row of phis (sampler
# scale of `old`): sum_k alpha_k log r_k over the length-scales whose
# kernel has a smoothness alpha (theta_k -> theta_k r_k^alpha_k, r_k the
# change of input k's range); every other map scales by a constant.
reweight_log_jacobian <- function(phis, old, new) {
  cls <- new$spec$classes
  ratio <- log((new$scale$xmax - new$scale$xmin) / (old$scale$xmax - old$scale$xmin))
  out <- numeric(nrow(phis))
  for (part in list(c("thetaS", "alphaS", "kernelS"), c("thetaB", "alphaB", "kernelB"))) {
    th <- which(cls == part[1])
    if (!length(th) || !kernel_has_alpha(new[[part[3]]])) next
    al <- which(cls == part[2])
    out <- out + drop(phis[, al, drop = FALSE] %*% input_ratio(ratio, part[1], length(th), new$scale))
  }
  out
}

# The inputs' ratios (of their ranges, or their logs) for the n
# length-scales of class cl ("thetaS": over the p + q inputs, "thetaB":
# the p experimental ones of scale sc), with independent outputs a copy
# per output.
input_ratio <- function(ratio, cl, n, sc) {
  per <- if (cl == "thetaS") sc$p + sc$q else sc$p
  ratio[(seq_len(n) - 1L) %% per + 1L]
}

# The output (1-based) each parameter of model's phi is in the units of:
# with independent outputs a perOutput class's copy its own, a
# measurement-error variance its noise group's (its field rows'), the rest
# the first's (with shared outputs one sigma2S spans them all).
param_outputs <- function(model) {
  cls <- model$spec$classes
  o <- model$spec$outputOf %||% integer(length(cls))
  e <- which(cls == "sigma2E")
  outF <- model$data$outF
  if (!is.null(outF)) {
    noise <- model$spec$model$noise %||% rep(1L, length(outF))
    o[e] <- outF[match(seq_along(e), noise)]
  }
  o[is.na(o) | o == 0L] <- 1L
  o
}

# The old runs and the new ones in one table of the old one's form.
bind_runs <- function(old, new, call = parent.frame()) {
  if (is.data.frame(old)) {
    if (!is.data.frame(new) && !is.matrix(new)) {
      cli::cli_abort("{.arg sim} must be a data frame with the columns of the fit's runs ({.val {names(old)}}), not {.obj_type_friendly {new}}.", call = call)
    }
    new <- as.data.frame(new)
    miss <- setdiff(names(old), names(new))
    if (length(miss)) {
      cli::cli_abort("{.arg sim} lacks the column{?s} {.val {miss}} of the fit's runs.", call = call)
    }
    return(rbind(old, new[names(old)]))
  }
  new <- as.matrix(new)
  if (!is.numeric(new) || ncol(new) != ncol(old)) {
    cli::cli_abort("{.arg sim} must be a numeric matrix of {ncol(old)} columns, as the fit's runs; it has {NCOL(new)}.", call = call)
  }
  if (!is.null(colnames(old)) && !is.null(colnames(new))) {
    miss <- setdiff(colnames(old), colnames(new))
    if (length(miss)) {
      cli::cli_abort("{.arg sim} lacks the column{?s} {.val {miss}} of the fit's runs.", call = call)
    }
    new <- new[, colnames(old), drop = FALSE]
  }
  rbind(old, new)
}

# A chain's start on `new` (the model on more runs) from its last state on
# `old`: the parameters mapped to the new scaling (warm_phi()), the
# proposals and the warm-up started afresh (initial_state()). Carrying the
# adapted scales, block shapes and adaptation counts over was measured
# slower: their small late steps re-tune slowly to the new posterior
# (the ball's refit, 3 replicates: warm-ups of 400-3400 sweeps a chain
# with them, 11 of 12 chains over 700; 300-500 without).
warm_state <- function(state, old, new) {
  initial_state(warm_phi(state$phi, old, new), new$spec)
}

# phi (sampler's scale; a vector, or a matrix with a row per draw) of
# model `old` in the scaling of `new`: kappa
# through its own units; theta_k * (range_new / range_old)^a (a = alpha_k
# for the power exponential, 2 otherwise: theta d^a is what the kernel
# sees; the latent noise GP's theta by the ranges' ratio squared);
# variances (the simulator's noise sigma2R too) by (sd_old / sd_new)^2, its
# log-variances gR and their mean muG by 2 log(sd_old / sd_new), and muB by
# the change of mean, each output's by its own (param_outputs()); fixed
# parameters at the new model's values.
warm_phi <- function(phi, old, new) {
  if (is.null(dim(phi))) return(warm_phi(matrix(phi, 1L), old, new)[1L, ])
  # one row per draw (reweight_runs()), one column per parameter
  so <- old$scale
  sn <- new$scale
  cls <- new$spec$classes
  p <- so$p
  q <- so$q
  n <- nrow(phi)
  out <- phi
  cal <- p + seq_len(q)
  k <- which(cls == "kappa")
  scaleCols <- function(X, a, b) X * rep(a, each = n) + rep(b, each = n)  # X_j a_j + b_j
  out[, k] <- scaleCols(phi[, k, drop = FALSE], (so$xmax[cal] - so$xmin[cal]) / (sn$xmax[cal] - sn$xmin[cal]),
                        (so$xmin[cal] - sn$xmin[cal]) / (sn$xmax[cal] - sn$xmin[cal]))
  ratio <- (sn$xmax - sn$xmin) / (so$xmax - so$xmin)
  stretch <- function(cl, al, kern) {
    i <- which(cls == cl)
    r <- rep(input_ratio(ratio, cl, length(i), sn), each = n)
    if (kernel_has_alpha(kern)) phi[, i] * r^phi[, which(cls == al)] else phi[, i] * r^2
  }
  th <- which(cls == "thetaS")
  out[, th] <- stretch("thetaS", "alphaS", new$kernelS)
  tb <- which(cls == "thetaB")
  if (length(tb)) out[, tb] <- stretch("thetaB", "alphaB", new$kernelB)
  tg <- which(cls == "thetaG")  # the latent log-variance GP's (Matern)
  out[, tg] <- phi[, tg] * rep(input_ratio(ratio, "thetaS", length(tg), sn)^2, each = n)
  # with several outputs each is standardised by its own runs' mean and sd
  o <- param_outputs(new)
  v <- which(cls %in% c("sigma2S", "sigma2B", "sigma2E", "sigma2R"))
  out[, v] <- phi[, v] * rep((so$ysd[o[v]] / sn$ysd[o[v]])^2, each = n)
  # the simulator's log-variances (input-dependent noise) shift by the same
  g <- which(cls %in% c("gR", "muG"))
  out[, g] <- phi[, g] + rep(2 * log(so$ysd[o[g]] / sn$ysd[o[g]]), each = n)
  mu <- which(cls == "muB")
  out[, mu] <- (phi[, mu] * rep(so$ysd[o[mu]], each = n) + rep(so$ymean[o[mu]] - sn$ymean[o[mu]], each = n)) /
    rep(sn$ysd[o[mu]], each = n)
  fixed <- new$spec$table$family == prior_families[["fixed"]]
  out[, fixed] <- rep(new$spec$init[fixed], each = n)
  out
}
