# The sampler: the compiled sampler called for one piece of a chain
# (sample_chain()), its initial state, and its moves: the schedule each
# sampler runs (sampler_moves(), read off the model description's `move`
# column) and what the compiled sampler reports of each move
# (move_report(), proposal_sd()). The compiled side (src/sampler.cpp) runs
# the schedule: one Move per entry, in the order of phi, then the scale
# move.

# The moves of each sampler (see vignette("sampler")), read off the
# model description's `move` column: index vectors of the jointly moved
# blocks (1-based, in phi; named by move) and how often each moves per
# sweep, the scale move (the `scaled` classes that have parameters), the
# exact draw of the "gibbs" class (when it has a parameter). `large`: a
# large simulator block on the dense algebra, where a move of the simulator
# block costs a Cholesky factor of it and a kappa move an m x m x n
# triangular solve: each moves once a sweep. `jump`: also a jump move of
# each free kappa with a proper prior (an independence proposal uniform
# over jump_ranges(), once a sweep after the walks: `jump`, 1-based in phi,
# and `jumpRange`, its interval on the sampler's scale, a row per jump),
# the default: a walk adapted within one mode of a multimodal kappa
# posterior rarely leaves it (simulator functions; with an
# emulator, Tuo and Wu's problem at 18-24 runs, where chains kept their
# modes for 25,000 draws: bench/RESULTS-design.md).
sampler_moves <- function(sampler, spec, large = FALSE, jump = TRUE) {
  if (jump) {
    out <- sampler_moves(sampler, spec, large, jump = FALSE)
    fam <- prior_family_name(spec$table$family)
    proper <- vapply(fam, function(f) prior_registry[[f]]$proper, logical(1), USE.NAMES = FALSE)
    out$jump <- which(spec$classes == "kappa" & proper & spec$table$b != 0)
    out$jumpRange <- jump_ranges(spec$table, out$jump)
    return(out)
  }
  if (sampler == "single") {
    return(list(blocks = list(), repeats = integer(), scale = FALSE, gibbsMuB = FALSE,
                params = spec$vars))
  }
  fam <- prior_family_name(spec$table$family)
  free <- fam != "fixed"
  row <- match(spec$classes, model_classes$class)
  move <- model_classes$move[row]
  # sigma2R joins the simulator block where the compiled core draws it from
  # the replicates' within term (tail_sigma2R(), src/sampler.cpp: more
  # than 2 within degrees of freedom and a positive within sum of squares);
  # else it moves alone
  rp <- spec$model$replicates
  if (!is.null(rp) && !(sum(rp$count - 1) > 2 && sum(rp$ssw) > 0)) {
    move[spec$classes == "sigma2R"] <- "single"
  }
  # each free parameter of an "each" class alone (a one-parameter block: its
  # walk scale adapts like the joint ones'), three moves a sweep (one when
  # `large`): a kappa move needs no m x m factorization, and kappa is what
  # the user came for
  each <- which(move == "each" & free)
  each <- stats::setNames(as.list(each), spec$vars[each])
  # with independent outputs (spec$outputOf) a joint block per output
  outOf <- spec$outputOf %||% integer(length(spec$vars))
  joint <- do.call(c, lapply(c("sim", "bias", "noise"), function(m) {
    idx <- which(move == m & free)
    by <- split(idx, outOf[idx])
    stats::setNames(by, if (length(by) > 1L) paste0(m, names(by)) else rep(m, length(by)))
  }))
  joint <- if (is.null(joint)) list() else joint[lengths(joint) >= 2L]
  scaled <- which(model_classes$scaled[row])
  gibbs <- which(move == "gibbs")
  rep_each <- if (large) 1L else 3L
  rep_joint <- as.integer(ifelse(startsWith(as.character(names(joint)), "sim") & large, 1L, 2L))
  # kappa's joint walk (the table's `joint`), beside each kappa's own walk
  # and jump: an overlay block, moved after the per-parameter moves
  # (src/sampler.cpp), with the covariance adapted from the chain's draws
  # as the GP blocks' is; with it each kappa's own walk moves once a sweep
  # (on a 5-kappa simulator function, bench/RESULTS-kappa.md: ESS per CPU
  # second twice that of three walks a sweep)
  together <- kappa_joint(spec, free, model_classes$joint[row])
  overlay <- if (length(together)) length(each) + length(joint) + 1L else integer()
  if (length(together)) rep_each <- 1L
  blocks <- c(each, joint, together)
  list(
    blocks = blocks,
    repeats = c(rep(rep_each, length(each)), rep_joint,
                rep(if (large) 1L else fbc_kappa_joint_repeats, length(together))),
    overlay = overlay,
    # the simulator blocks whose sigma2S is drawn from the runs' own
    # conditional (src/sampler.cpp, BlockMove; only where the algebra gives
    # ys' Ds^-1 ys ahead of a proposal, the Vecchia one: elsewhere the plain
    # joint walk): at m = 1000 (bench/RESULTS-defaults.md) the joint
    # walk's mixing of sigma2S and the length-scales limited the run
    collapse = unname(which(startsWith(as.character(names(blocks)), "sim") &
                       vapply(blocks, function(b) spec$classes[b[length(b)]] == "sigma2S", logical(1)))),
    scale = all(free[scaled]),
    gibbsMuB = length(gibbs) > 0L &&
      all(free[gibbs] & fam[gibbs] == "gaussian" & spec$table$a[gibbs] == 0 &
            spec$table$b[gibbs] == 1),
    # the simulator blocks that, after a warm-up of data-dependent length,
    # propose from the warm-up's estimate of their posterior (a multivariate
    # t; src/sampler.cpp, BlockMove) instead of walking: the m runs pin the
    # simulator GP's parameters down to a nearly Gaussian posterior on the
    # walk's scale, which a walk crosses slowly (at m = 1000 the length-
    # scales' bulk ESS was 0.03-0.05 a sweep, within 2x of what an optimally
    # scaled 4-parameter walk can do). Blocks of 2 to 4 walked parameters
    # (not at 5: see IND_MAX_K in src/sampler.cpp): on the ball drop (3)
    # the walk's thetaS1 set the run's length; proposing from the warm-up's
    # estimate, the default run took 2.8-4.6 CPU s over seeds 1-5 against
    # 4.6-7.4. The bias blocks walk: proposing so there too cut the ball
    # further (2.8-3.8 s) but ran m = 1000 (seed 1) to 5950 sweeps against
    # 4200
    independent = unname(which(startsWith(as.character(names(blocks)), "sim"))),
    params = spec$vars
  )
}

# Kappa's joint block: the free parameters of the `joint` classes (walked:
# prior scale b != 0), as one block named by its class, when there are at
# least two; else none.
kappa_joint <- function(spec, free, joint) {
  idx <- which(joint & free & spec$table$b != 0)
  if (length(idx) < 2L) return(list())
  stats::setNames(list(idx), spec$classes[idx[1]])
}
# (three a sweep, once on a large dense problem: one move costs what one
# kappa's walk costs, one call of a simulator function or one kappa move's
# algebra)
fbc_kappa_joint_repeats <- 3L

# The report of a fit's moves, one row per move of the schedule: its kind
# ("walk": a one-parameter adapted walk, "joint", "independent": a joint
# block proposing from its warm-up estimate after warm-up, "single",
# "gibbs", "scale"; the kind chain 1 ran), the parameters it moves, its
# repeats per sweep, its acceptance
# rate over the retained sweeps of all chains (accepted / tries), and its
# adapted proposal scale (exp(s) of its walk; for a "single" move its SD on
# the walk's scale), the geometric mean over the chains. NULL for fits made
# before moves were reported.
move_report <- function(fit) {
  ms <- lapply(fit$state$chains, function(s) s$sampler$moves)
  if (any(vapply(ms, is.null, logical(1)))) return(NULL)
  all <- pool_moves(ms)
  scale <- exp(Reduce(`+`, lapply(ms, function(m) log(m$scale))) / length(ms))
  data.frame(move = all$name, kind = all$kind, parameters = all$params,
             repeats = all$repeats, acceptance = move_rates(all),
             scale = scale, stringsAsFactors = FALSE)
}

# The chains' move records (each chain's state$moves, the same schedule)
# as one: accepted and tries summed over the chains.
pool_moves <- function(ms) {
  out <- ms[[1]]
  out$accepted <- Reduce(`+`, lapply(ms, `[[`, "accepted"))
  out$tries <- Reduce(`+`, lapply(ms, `[[`, "tries"))
  out
}

# Each move's acceptance rate over the retained sweeps: accepted / tries
# (NA before a retained try).
move_rates <- function(moves) {
  ifelse(moves$tries > 0, moves$accepted / moves$tries, NA_real_)
}

# The acceptance of each parameter of `vars` (named by them), from a moves
# record (a chain's state$moves, or pool_moves() of all chains'): the rate
# of the move that moves it (NA: fixed, or no retained try yet); the scale
# move's rate apart, as attribute "scale" (NA without one); a jump move
# (function simulators) is reported by name only. The compiled
# sampler counts acceptance once, per move; this is the only place it
# becomes per parameter. `moves` NULL (a fit from before moves were
# reported): the rates `stored` kept (a chain's state: acceptance,
# scaleAcceptance).
move_acceptance <- function(moves, vars, stored = NULL) {
  if (is.null(moves)) {
    acc <- stored$acceptance %||% stats::setNames(rep(NA_real_, length(vars)), vars)
    return(structure(acc, scale = stored$scaleAcceptance %||% NA_real_))
  }
  acc <- stats::setNames(rep(NA_real_, length(vars)), vars)
  rate <- move_rates(moves)
  done <- rep(NA, length(vars))
  scale <- NA_real_
  for (i in seq_along(rate)) {
    if (moves$kind[i] == "scale") {
      scale <- rate[i]
    } else if (moves$kind[i] != "jump") {  # a jump: by name only (kappa's rate is its walk's)
      # an overlay (kappa's joint walk) after a parameter's own move: by name only
      at <- match(strsplit(moves$params[i], ",", fixed = TRUE)[[1]], vars)
      at <- at[is.na(done[at])]
      acc[at] <- rate[i]
      done[at] <- TRUE
    }
  }
  structure(acc, scale = scale)
}

# The fit's acceptance per parameter (chain states `states`, see
# new_fbc_chains()): that of the chains' moves pooled (the move report's,
# print()); the mean of the chains' kept rates for chains from before moves
# were reported.
fit_acceptance <- function(states, vars) {
  ms <- lapply(states, function(s) s$sampler$moves)
  if (!any(vapply(ms, is.null, logical(1)))) return(c(move_acceptance(pool_moves(ms), vars)))
  Reduce(`+`, lapply(states, function(s) s$acceptance)) / length(states)
}

# The proposal SD of each parameter of phi on its walk's scale, from a
# chain's sampler state: exp(logsd) for a single-site move; for a joint or
# one-parameter adapted move exp(s) times the SD its shape L gives the
# parameter (sqrt of the row sums of L^2): the marginal step of the
# proposal actually made. NA for a parameter drawn exactly (gibbs) or not
# moved (fixed).
proposal_sd <- function(state, vars, fixed) {
  sd <- stats::setNames(exp(state$logsd), vars)
  for (b in state$blocks) {
    if (isTRUE(b$overlay)) next  # kappa's joint walk: each kappa's own walk is reported
    sd[b$index] <- exp(b$logscale) * sqrt(rowSums(as.matrix(b$chol)^2))
  }
  m <- state$moves
  if (!is.null(m)) {
    gibbs <- m$kind == "gibbs"
    sd[match(m$params[gibbs], vars)] <- NA_real_
  }
  sd[fixed] <- NA_real_
  sd
}

# Runs the compiled sampler for `nIter` further sweeps from `state` (the
# sampler's whole state on its own scale: see initial_state()); sweeps up to
# `nBurn` (counted from the chain's start) adapt the proposals, or, when
# `nBurn` is a warm-up's bounds (list(min, max)), sweeps until the
# proposals have settled (src/sampler.cpp). An interrupt
# (Ctrl-C) is reported in the result (`interrupted`, `done`, `kept`), not as
# a condition: the caller decides what to say.
sample_chain <- function(dat, spec, state, moves, nIter, nBurn, thinning, showProgress,
                         sampler = fbc_sampler_hook()) {
  progress <- if (showProgress) {
    list(name = "Calibrating", clear = TRUE, show_after = 0,
         format = "{cli::pb_name} {cli::pb_bar} {cli::pb_percent} | ETA: {cli::pb_eta} | {cli::pb_status}")
  }
  if (is.list(nBurn)) {
    # the bounds travel in the state; -1: a warm-up of data-dependent length
    state$warmMin <- state$warmMin %||% as.integer(nBurn$min)
    state$warmMax <- state$warmMax %||% as.integer(nBurn$max)
    state$warmESS <- state$warmESS %||% as.numeric(nBurn$ess %||% 0)
    state$warmForget <- state$warmForget %||% as.numeric(nBurn$forget %||% 0)
    nBurn <- -1L
  }
  if (length(moves$jump) && is.null(moves$jumpRange)) {
    # a fit made before the ranges were stored with its moves
    moves$jumpRange <- jump_ranges(spec$table, moves$jump)
  }
  sampler(dat$Xf, dat$yf, dat$Xs, dat$ys, as.list(spec$table), moves, state, nIter, nBurn,
          thinning, fbc_nugget, progress, model = spec$model)
}

# The interval the jump move of each parameter `j` (1-based rows of the
# prior table) proposes from, uniformly, on the sampler's scale x (the
# prior's argument is a + b x): the prior's support where it is bounded
# (uniform, beta: the whole posterior is within reach), else its central
# 99.9% (a gaussian or logistic kappa: from a point outside it the jump is
# rejected, which keeps the posterior invariant; the walk covers the tails).
# A matrix, a row per parameter (lower, upper).
jump_ranges <- function(table, j) {
  out <- matrix(NA_real_, length(j), 2, dimnames = list(NULL, c("lower", "upper")))
  for (r in seq_along(j)) {
    i <- j[r]
    fam <- prior_family_name(table$family[i])
    s <- family_support(fam, table$p1[i], table$p2[i])
    q <- prior_quantile(c(0.0005, 0.9995), fam, table$p1[i], table$p2[i])
    v <- ifelse(is.finite(s), s, q)
    out[r, ] <- sort((v - table$a[i]) / table$b[i])
  }
  out
}

# The state a chain starts from: parameters `init` (sampler's scale), the
# initial proposal SDs, no iteration done. The compiled sampler fills in the
# rest (adaptation sums, blocks) and returns the state it stopped in.
initial_state <- function(init, spec) {
  list(phi = unname(init), logsd = unname(spec$logsd), iter = 0L, batch = 0L)
}

# The compiled sampler. Tests replace it (options(FBC.sampler = f)) by a
# wrapper that imitates a Ctrl-C, to check what an interrupted run returns.
fbc_sampler_hook <- function() getOption("FBC.sampler", .fbc_sample)
