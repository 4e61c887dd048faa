# The fit object (class "fbc"), made by calibrate() and update().
#
# new_fbc() is its one constructor: it takes the parts, derives the
# user-facing copies of the model description (`priors`, `vars`, `indices`,
# `priorFns`, documented in ?calibrate) from the model's `spec`, stamps the
# format version and validates. The fit holds its model (`model`, an
# fbc_model: data, scale, spec, ...) and its run; package code reads the
# model's parts (fit$model$spec: phi_vars(), phi_indices(), spec$fns,
# spec$priors), not those copies.
#
# validate_fbc() checks the structure. upgrade_fbc() brings a fit or a
# checkpoint file written by an earlier FBC to the current format; every
# function that receives a fit goes through it (check_fbc()), and the
# checkpoint loader (read_checkpoint_file()) too.

# Format of the fit: fit$version$format. Fits made before it existed have
# no `version` (format 0), format 1 fits no discrepancy model, format 2
# fits a layout without the S-GaSP scale, format 3 fits no model object
# (the model's choices among the settings), format 4 fits with several
# outputs no `outputs` choice (they were shared), format 5 fits the algebra
# twice (model$algebra, chosen, beside model$simAlgebra, run, without the
# product design's size), format 6 fits copies of the model's data, scale
# and spec beside the model (fit$data, fit$scale, fit$spec); upgrade_fit()
# brings each to the current format by the steps keyed by format in
# fit_upgrades.
fbc_fit_format <- 7L

# ------------------------------------------------------------ constructor ----

new_fbc <- function(Phi, chain, logPost, logLik, acceptance, proposalSD, model, settings, state,
                    call, estimates = estimate_table(Phi, chain)) {
  spec <- model$spec
  x <- structure(list(
    Phi = Phi,
    chain = chain,
    estimates = estimates,
    logPost = logPost,
    priors = spec$priors,
    acceptance = acceptance,
    vars = phi_vars(spec),
    indices = phi_indices(spec),
    priorFns = spec$fns,
    proposalSD = proposalSD,
    call = call,
    settings = settings,
    logLik = logLik,
    state = state,
    model = model,
    version = list(fbc = as.character(utils::packageVersion("FBC")), format = fbc_fit_format)
  ), class = "fbc", cache = fit_cache())
  validate_fbc(x)
}

# The names of Phi's columns: the sampler's parameters (spec$vars) but the
# smoothness of a family without one (phi_columns()).
phi_vars <- function(spec) spec$vars[phi_columns(spec)]

# Assembles an fbc object from a list of chain results (each as returned by
# .fbc_sample, draws on the sampler's scale) of `model` (an fbc_model).
# `prev` is an earlier fbc object whose draws the new ones are appended to
# (update()), or NULL.
new_fbc_chains <- function(results, model, call, settings, prev = NULL) {
  spec <- model$spec
  scale <- model$scale
  p <- scale$p
  q <- scale$q
  cal <- p + seq_len(q)
  # Phi holds the columns of phi that are parameters of the model (not the
  # smoothness of a family without one): phi_columns()
  cols <- phi_columns(spec)
  pieces <- lapply(seq_along(results), function(k) {
    r <- results[[k]]
    kept <- seq_len(r$kept)
    Phi <- r$draws[kept, cols, drop = FALSE]
    colnames(Phi) <- spec$vars[cols]
    Phi[, seq_len(q)] <- unscale_inputs(Phi[, seq_len(q), drop = FALSE], scale, cal)
    list(Phi = Phi, logPost = r$logPost[kept], logLik = r$logLik[kept])
  })
  states <- lapply(seq_along(results), function(k) {
    r <- results[[k]]
    # acceptance over all retained sweeps of the fit: the moves' counts
    # (carried through every update()); a chain still without them (a fit
    # from before moves were reported, skipped after an interrupt) keeps its
    # old rates
    acc <- move_acceptance(r$state$moves, spec$vars, stored = prev$state$chains[[k]])
    logsd <- stats::setNames(r$state$logsd, spec$vars)
    list(last = r$state$phi, logsd = logsd, done = r$done, nPost = r$nPost,
         interrupted = r$interrupted, acceptance = c(acc),
         scaleAcceptance = attr(acc, "scale"), kept = r$kept, sampler = r$state)
  })
  if (!is.null(prev)) {
    # append chain k's new draws after its old ones
    old <- split_chains(prev)
    pieces <- lapply(seq_along(pieces), function(k) {
      list(Phi = rbind(old[[k]]$Phi, pieces[[k]]$Phi),
           logPost = c(old[[k]]$logPost, pieces[[k]]$logPost),
           logLik = c(old[[k]]$logLik, pieces[[k]]$logLik))
    })
    states <- lapply(seq_along(states), function(k) {
      s <- states[[k]]
      o <- prev$state$chains[[k]]
      s$postDone <- o$postDone + s$nPost
      s$done <- o$done + s$done
      s$kept <- o$kept + s$kept
      s
    })
  } else {
    states <- lapply(states, function(s) {
      s$postDone <- s$nPost
      s
    })
  }
  Phi <- do.call(rbind, lapply(pieces, `[[`, "Phi"))
  rownames(Phi) <- NULL
  chain <- rep(seq_along(pieces), vapply(pieces, function(x) nrow(x$Phi), integer(1)))
  # the proposal actually made, per parameter (blocks included): the
  # geometric mean over the chains
  fixed <- spec$table$family == prior_families[["fixed"]]
  logSD <- lapply(states, function(s) log(proposal_sd(s$sampler, spec$vars, fixed)))
  new_fbc(
    Phi = Phi, chain = chain,
    logPost = unlist(lapply(pieces, `[[`, "logPost")),
    logLik = unlist(lapply(pieces, `[[`, "logLik")),
    acceptance = fit_acceptance(states, spec$vars)[cols],
    proposalSD = exp(Reduce(`+`, logSD) / length(states))[cols],
    model = model, settings = settings,
    state = list(chains = states,
                 interrupted = any(vapply(states, `[[`, logical(1), "interrupted"))),
    call = call
  )
}

# The draws of each chain: list of list(Phi, logPost, logLik).
split_chains <- function(x) {
  lapply(sort(unique(x$chain)), function(k) {
    i <- x$chain == k
    list(Phi = x$Phi[i, , drop = FALSE], logPost = x$logPost[i], logLik = x$logLik[i])
  })
}

# -------------------------------------------------------------- validator ----

# Checks the structure of an fbc object; returns it (invisibly) or aborts
# with one line per problem found.
validate_fbc <- function(x, arg = "x", call = parent.frame()) {
  abort_problems(fbc_problems(x), "{.arg {arg}} is not a valid {.cls fbc} object:", arg, call)
  invisible(x)
}

# The one error of a validator: `head` (cli markup; {arg} is the argument)
# and a line per problem; nothing when there is none.
abort_problems <- function(bad, head, arg, call) {
  if (!length(bad)) return(invisible())
  cli::cli_abort(c(head, stats::setNames(bad, rep("x", length(bad)))), call = call)
}

# The problems of an fbc object, in words (character(0) when none). A check
# runs only when the parts it reads are sound, so one fault is reported
# once.
fbc_problems <- function(x) {
  if (!inherits(x, "fbc") || !is.list(x)) return("It is not a list of class {.cls fbc}.")
  need <- c("Phi", "chain", "estimates", "logPost", "acceptance", "proposalSD", "settings",
            "logLik", "state", "model", "version")
  miss <- setdiff(need, names(x))
  if (length(miss)) return(sprintf("`%s` is missing.", miss))
  out <- character()
  v <- x$version
  if (!is.list(v) || !is_count(v$format) || !is.character(v$fbc)) {
    out <- c(out, "`version` must be a list with `fbc` (a version string) and `format` (an integer).")
  }
  Phi <- x$Phi
  if (!is.matrix(Phi) || !is.numeric(Phi)) return(c(out, "`Phi` must be a numeric matrix."))
  # the draws: one value of each per row of Phi, one state per chain
  n <- nrow(Phi)
  for (el in c("chain", "logPost", "logLik")) {
    if (length(x[[el]]) != n) {
      out <- c(out, sprintf("`%s` has %d values for the %d rows of `Phi`.", el, length(x[[el]]), n))
    }
  }
  chains <- x$state$chains
  K <- length(chains)
  if (!is.list(chains) || !K) {
    out <- c(out, "`state$chains` must hold one state per chain.")
  } else if (length(x$chain) == n) {
    if (!all(x$chain %in% seq_len(K)) || !all(seq_len(K) %in% x$chain)) {
      out <- c(out, sprintf("`chain` must number the rows of `Phi` by chain, 1 to %d (one per state in `state$chains`), each at least once.", K))
    } else {
      kept <- vapply(chains, function(st) as.numeric(st$kept %||% NA), numeric(1))
      rows <- tabulate(x$chain, K)
      for (k in which(is.na(kept) | kept != rows)) {
        out <- c(out, sprintf("`state$chains[[%d]]` kept %s draws; `chain` has %d rows of chain %d.",
                              k, format(kept[k]), rows[k], k))
      }
    }
  }
  c(out, fbc_spec_problems(x))
}

# The problems of an fbc object's model and of what follows it: Phi's
# columns and everything per parameter follow the model's `spec`.
fbc_spec_problems <- function(x) {
  out <- character()
  Phi <- x$Phi
  chains <- x$state$chains
  K <- length(chains)
  # the model (an fbc_model) first: its spec is the one everything follows
  if (!inherits(x$model, "fbc_model") || !is.list(x$model)) {
    return(c(out, paste("`model`:", fbc_model_problems(x$model))))
  }
  spec <- x$model$spec
  miss <- setdiff(c("table", "init", "logsd", "vars", "classes", "priors", "fns", "model"), names(spec))
  if (length(miss)) return(c(out, sprintf("`model$spec$%s` is missing.", miss)))
  d <- length(spec$vars)
  if (NROW(spec$table) != d || length(spec$init) != d || length(spec$classes) != d) {
    return(c(out, sprintf("`model$spec$table`, `model$spec$init` and `model$spec$classes` must describe the %d parameters of `model$spec$vars`.", d)))
  }
  mp <- fbc_model_problems(x$model)
  if (length(mp)) return(c(out, paste("`model`:", mp)))
  # the layout the compiled core gets is the model description's for these
  # data (R/model-classes.R)
  sc <- x$model$scale
  dm <- x$model$dims
  disc <- discrepancy_name(spec$model$discrepancy)
  if (length(disc) != 1L || is.na(disc)) {
    return(c(out, sprintf("`model$spec$model$discrepancy` must be a discrepancy code (%s).",
                          paste(sprintf("%d for %s", discrepancy_codes, names(discrepancy_codes)), collapse = ", "))))
  }
  if (!identical(spec$model[c("offset", "length")], layout_codes(sc$p, sc$q, disc, dm$noise, dm$levels,
                                                   if (disc == "none") 0L else dm$sources,
                                                   outputs = dm$outputs %||% 1L,
                                                   emulator = x$model$algebra$name != "function",
                                                   replicates = noise_sizes(spec$model$replicates),
                                                   asked = asked_classes(compiled = spec$model)))) {
    return(c(out, sprintf("`model$spec$model` must hold the layout of phi for p = %d, q = %d and discrepancy \"%s\" (offset and length by class).",
                          sc$p, sc$q, disc)))
  }
  vars <- phi_vars(spec)
  if (!identical(colnames(Phi), vars)) {
    out <- c(out, sprintf("`Phi` has columns %s; the model's parameters are %s.",
                          format_names(colnames(Phi)), format_names(vars)))
  }
  for (el in c("acceptance", "proposalSD")) {
    if (length(x[[el]]) != length(vars)) {
      out <- c(out, sprintf("`%s` has %d values for the model's %d parameters.", el, length(x[[el]]), length(vars)))
    }
  }
  if (!is.data.frame(x$estimates) || !identical(rownames(x$estimates), vars)) {
    out <- c(out, "`estimates` must be a data frame with one row per parameter of the model.")
  }
  for (k in seq_len(if (is.list(chains)) K else 0L)) {
    s <- chains[[k]]$sampler
    if (!is.list(s) || length(s$phi) != d || length(s$logsd) != d || !is_count(s$iter)) {
      out <- c(out, sprintf("`state$chains[[%d]]$sampler` must be a sampler state: `phi` and `logsd` of length %d, `iter`.", k, d))
    }
  }
  out
}

# A whole number, 0 or more.
is_count <- function(x) is.numeric(x) && length(x) == 1L && !is.na(x) && x >= 0 && x == round(x)

# Names for a message: "a, b, c" or "none".
format_names <- function(x) if (length(x)) paste(x, collapse = ", ") else "none"

# ---------------------------------------------------------------- upgrade ----

# Brings an object written by an earlier FBC up to the current format: a
# fit (class "fbc") or the contents of a checkpoint file (run.rds,
# chain-<k>.rds: see checkpoint.R). A current object is returned as is; one
# from a newer FBC is refused. Each step is what an earlier version did not
# write, filled in as that version behaved.
upgrade_fbc <- function(x, call = parent.frame()) {
  if (inherits(x, "fbc")) upgrade_fit(x, call) else upgrade_checkpoint(x, call)
}

upgrade_fit <- function(x, call) {
  format <- if (is.null(x$version)) 0L else x$version$format
  if (identical(format, fbc_fit_format)) {
    # (fits of this format written before the compiled model held the
    # classes' roles and the field rows' grouping get them)
    x$model$spec$model <- complete_compiled_model(x$model$spec$model, x$model$data$Xf)
    return(x)
  }
  if (!is_count(format) || format > fbc_fit_format) {
    cli::cli_abort(c(
      "This {.cls fbc} object was made by a newer FBC ({x$version$fbc}, format {format}); this is FBC {utils::packageVersion('FBC')} (format {fbc_fit_format}).",
      i = "Update FBC to use it."
    ), call = call)
  }
  # one step after the other, each keyed by the format it starts from
  # (fit_to_4() constructs the fit anew); the result is validated
  while (format < fbc_fit_format) {
    x <- fit_upgrades[[as.character(format)]](x)
    format <- x$version$format
  }
  validate_fbc(x, call = call)
  x
}

# Formats 0 to 2 to 3: what each earlier version did not write, filled in
# as that version behaved (a step changes nothing a fit already has).
fit_to_3 <- function(x) {
  # format 0: every fit made before the version existed; format 1: before
  # the discrepancy models. What each earlier version left out (a step
  # changes nothing a fit already has):
  spec <- x$spec
  s <- x$settings
  sc <- x$scale
  # - the model codes (before the kernels and algebras: the power
  #   exponential on both GPs, the algebra chosen by the design)
  # - and the layout of phi (before R handed it to the compiled core: the
  #   one layout there was, which the model description still gives)
  # - the discrepancy model (format 1, before the choice: the bias GP)
  # - the S-GaSP scale in the layout (format 2: a class of length 0 for
  #   the models it had)
  mc <- spec$model
  spec$model <- compiled_model(sc$p, sc$q, mc$kernS %||% 1L, mc$kernB %||% 1L,
                               mc$algebra %||% 0L,
                               discrepancy_name(mc$discrepancy %||% discrepancy_codes[["gp"]]))
  # - the column names' use (before columns were matched by name: by
  #   position)
  if (is.null(sc$named)) sc$named <- FALSE
  # - the settings of later options, at what the run did: one chain, the
  #   single-site sampler (0.1.0's thetaS/alphaS block move, `blockSim`, is
  #   not continued: update() goes on with single-site moves), the power
  #   exponential, the design's algebra
  s$nChains <- s$nChains %||% 1L
  if (is.null(s$moves)) {
    s$sampler <- s$sampler %||% "single"
    s$moves <- sampler_moves(s$sampler, spec, jump = FALSE)
    s$blockSim <- NULL
  }
  # - the moves' parameter names (before each move was reported by name)
  s$moves$params <- s$moves$params %||% spec$vars
  s$kernelS <- s$kernelS %||% "powexp"
  s$kernelB <- s$kernelB %||% "powexp"
  s$discrepancy <- s$discrepancy %||% "gp"
  s$algebra <- s$algebra %||% "auto"
  # - the chains (before several chains: one, its state at the top of
  #   `state`)
  chain <- x$chain %||% rep(1L, nrow(x$Phi))
  chains <- x$state$chains
  if (is.null(chains)) {
    st <- x$state
    chains <- list(list(last = st$last, logsd = st$logsd, batch = st$batch, done = st$done,
                        interrupted = isTRUE(st$interrupted), acceptance = x$acceptance,
                        kept = nrow(x$Phi), postDone = max(0, st$done - s$nBurn)))
  }
  # - the sampler's state (before the sampler took its state in and gave
  #   it back: where the chain stopped, its proposal scales and the
  #   adaptation batch; 0.1.0's `block` goes with `blockSim`), the scale
  #   move's acceptance (no scale move then)
  chains <- lapply(chains, function(st) {
    if (is.null(st$sampler)) {
      st$sampler <- list(phi = unname(st$last), logsd = unname(st$logsd),
                         iter = as.integer(st$done), batch = as.integer(st$batch))
      st$block <- NULL
    }
    if (is.null(st$scaleAcceptance)) st$scaleAcceptance <- NA_real_
    st
  })
  # - R-hat and ESS (before several chains)
  est <- x$estimates
  if (is.null(est$rhat) || is.null(est$ess)) est <- estimate_table(x$Phi, chain)
  x[c("chain", "estimates", "spec", "scale", "settings")] <- list(chain, est, spec, sc, s)
  x$state <- list(chains = chains, interrupted = any(vapply(chains, function(st) isTRUE(st$interrupted), logical(1))))
  x$version <- list(fbc = x$version$fbc %||% "0.1.0", format = 3L)
  x
}

# Format 3 to 4: the model of the fit becomes an object (fit$model, an
# fbc_model) and the settings keep the run's only.
fit_to_4 <- function(x) {
  s <- x$settings
  model <- model_of_fit(x)
  run <- c("nMCMC", "nBurn", "thinning", "nChains", "nugget", "time", "checkpoint", "converge")
  out <- new_fbc(
    Phi = x$Phi, chain = x$chain, logPost = x$logPost, logLik = x$logLik,
    acceptance = x$acceptance, proposalSD = x$proposalSD, model = model,
    settings = s[intersect(names(s), run)], state = x$state, call = x$call,
    estimates = x$estimates
  )
  # format 4 (new_fbc() stamps the current one and keeps no copies of the
  # model's parts beside it): the later steps follow
  out$version$format <- 4L
  out
}

# The fbc_model of a format-3 fit, from its data, scale, spec and settings
# (the unscaled data were not kept: `raw` is NULL).
model_of_fit <- function(x) {
  s <- x$settings
  sc <- x$scale
  mc <- x$spec$model
  algebra <- old_fit_algebra(x)
  bias <- if (!is.null(mc$source)) list(codes = mc$source, L = mc$sourceLevels)
  design <- list(factors = sc$factors, output = sc$output, source = sc$source, noise = mc$noise,
                 noiseLabels = sc$noiseLabels, levels = mc$levels, biasSource = bias,
                 outputs = mc$outputs)
  new_fbc_model(data = x$data, raw = NULL, scale = sc, design = design, spec = x$spec,
                kernelS = s$kernelS, kernelB = s$kernelB, discrepancy = s$discrepancy,
                sampler = s$sampler %||% "single", algebra = algebra,
                moves = s$moves,
                options = list(algebra = s$algebra, neighbours = s$neighbours, output = s$output,
                               source = s$source, sourceBias = s$sourceBias %||% "shared"),
                call = x$call)
}

# Format 4 to 5: several outputs became independent by default
# (calibrate(outputs =), R/outputs.R); a fit with several outputs made
# before was a shared model, said in its options and calls so that a refit
# from them builds the same model.
fit_to_5 <- function(x) {
  if (!is.null(x$model$options$output)) {
    x$model$options$outputs <- "shared"
    if (!is.null(x$model$call)) x$model$call$outputs <- "shared"
    if (!is.null(x$call)) x$call$outputs <- "shared"
  }
  x$version$format <- 5L
  x
}

# The algebra record (as choose_algebra() makes it) of a format-3 fit: from
# the simAlgebra its settings kept, or (fits before it kept one) from the
# product design the compiled core finds under the model's algebra code.
old_fit_algebra <- function(x) {
  s <- x$settings
  mc <- x$spec$model
  vecchia <- identical(mc$algebra, algebra_codes[["vecchia"]])
  dims <- if (!is.null(s$simAlgebra)) s$simAlgebra$dims else if (!vecchia) {
    .sim_algebra(x$data$Xs, x$scale$p, mc$algebra)
  }
  name <- if (vecchia) "vecchia" else if (length(dims)) "kronecker" else "dense"
  list(name = name, code = mc$algebra, neighbours = mc$vecchia$k,
       forced = !identical(s$algebra %||% "auto", "auto"),
       reason = s$simAlgebra$reason,  # NULL: the FBC that made it gave none
       dims = if (length(dims)) dims)
}

# Format 5 to 6: the algebra is one record, model$algebra (with the product
# design's size, `dims`), no longer restated by a model$simAlgebra.
fit_to_6 <- function(x) {
  m <- x$model
  if (!is.null(m$simAlgebra)) {
    m$algebra["dims"] <- list(if (identical(m$algebra$name, "kronecker")) m$simAlgebra$dims)
    m$simAlgebra <- NULL
    x$model <- m
  }
  x$version$format <- 6L
  x
}

# Format 6 to 7: the fit holds its model only. The copies of the model's
# data, scale and spec beside it go; a part the model lacks is the fit's
# copy. The model's dims state the number of independent outputs.
fit_to_7 <- function(x) {
  parts <- c("data", "scale", "spec")
  for (el in parts) {
    if (is.null(x$model[[el]])) x$model[el] <- list(x[[el]])
  }
  # (the number of independent outputs joined the model's dims with them)
  if (is.null(x$model$dims$outputs)) x$model$dims$outputs <- output_count(x$model$spec$model)
  # (and the compiled model the classes' roles and the field rows' grouping)
  x$model$spec$model <- complete_compiled_model(x$model$spec$model, x$model$data$Xf)
  x[parts] <- NULL
  x$version$format <- 7L
  x
}

fit_upgrades <- list(`0` = fit_to_3, `1` = fit_to_3, `2` = fit_to_3, `3` = fit_to_4,
                     `4` = fit_to_5, `5` = fit_to_6, `6` = fit_to_7)

# The contents of a checkpoint file of format `x$format` (at most
# fbc_checkpoint_format: read_checkpoint_file() refuses newer ones). Format
# 1 is the only one written so far (checkpoints came with it): no step yet.
# The run's identity (run_identity()) is never rewritten: it must match the
# call that resumes the run.
upgrade_checkpoint <- function(x, call) {
  x
}

# The gate of every function that takes a fit: refuses what is not one and
# returns it in the current format (upgrade_fbc()).
check_fbc <- function(x, arg = "fit", call = parent.frame()) {
  if (!inherits(x, "fbc")) {
    cli::cli_abort("{.arg {arg}} must be an {.cls fbc} object from {.fn calibrate}, not {.obj_type_friendly {x}}.",
                   call = call)
  }
  # an earlier format is brought up to date (and validated on the way);
  # a current one is validated here
  if (identical(x$version$format, fbc_fit_format)) validate_fbc(x, arg, call = call) else
    upgrade_fbc(x, call = call)
}
