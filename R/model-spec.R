# The model spec of one fit: the model description (R/model-classes.R) expanded
# for its data and priors -- one prior row, initial value and proposal SD
# per parameter of phi -- and the maps between phi, Phi's columns and
# draws on the sampler's scale.

# The hyperparameter priors with the smoothness of a GP whose family has
# none (see ?correlation) fixed (at 2, a value the compiled kernels ignore):
# it is not sampled, and phi_columns() leaves it out of Phi. A prior the
# user gave for it is ignored, with a warning naming the arguments.
kernel_hypers <- function(hypers, kernelS, kernelB, call = parent.frame()) {
  default <- set_hyperPriors()
  kernels <- c(kernelS = kernelS, kernelB = kernelB)
  for (cls in smooth_classes) {
    if (is.null(hypers[[cls]])) next  # no such class in this model (discrepancy_hypers())
    kernel <- kernels[[kernel_arg(cls)]]
    if (kernel_has_alpha(kernel)) next
    given <- !mapply(identical, hypers[[cls]], default[[cls]])
    if (any(given)) {
      args <- paste0("`", cls, c("Dist", "Init", "P1", "P2")[given], "`")
      K <- kernel_arg(cls)
      cli::cli_warn(c(
        sprintf("`%s = \"%s\"` has no smoothness parameter: %s of `hypers` %s ignored.",
                K, kernel, paste(args, collapse = ", "), if (length(args) > 1L) "are" else "is"),
        i = sprintf("`%s` is not sampled with this family. Drop %s from `set_hyperPriors()`, or use `%s = \"powexp\"` to sample it.",
                    cls, if (length(args) > 1L) "these arguments" else "this argument", K)
      ), call = call)
    }
    hypers[[cls]] <- list(dist = "fixed", init = 2, p1 = NA_real_, p2 = NA_real_)
  }
  hypers
}

# The indicator columns of categorical inputs (their positions `pos` among
# the p experimental inputs) enter neither GP's separable kernel: their
# thetaS and thetaB are held at 0 and their alphaS and alphaB at 2 (d^alpha
# = d on {0, 1}); the levels' correlation is rhoS's and rhoB's (see
# R/factors.R and src/levels.cpp).
indicator_hypers <- function(hypers, pos, p, q) {
  pos <- pos[!is.na(pos)]
  if (!length(pos)) return(hypers)
  held <- c(thetaS = 0, thetaB = 0, alphaS = 2, alphaB = 2)
  for (cls in names(held)) {
    h <- hypers[[cls]]
    if (is.null(h)) next
    n <- if (cls %in% c("thetaS", "alphaS")) p + q else p
    h <- lapply(h, function(v) rep_len(v, n))
    h$dist[pos] <- "fixed"
    h$init[pos] <- held[[cls]]
    hypers[[cls]] <- h
  }
  hypers
}

# The hyperparameter priors of the discrepancy model: the classes it does
# not have (class_in_model(): all of the bias GP's without one, and those
# of the bias GP its row in discrepancy_models does not name) have no
# parameters, so a prior the user gave for one, or a
# bias correlation family other than the default (calibrate()'s
# "matern52") without a bias, is ignored with a warning naming
# the arguments.
discrepancy_hypers <- function(hypers, discrepancy, kernelB, call = parent.frame()) {
  if (discrepancy == "none" && kernelB != "matern52") {
    cli::cli_warn(sprintf("`kernelB = \"%s\"` is not used: `discrepancy = \"%s\"` has no bias GP.",
                          kernelB, discrepancy), call = call)
  }
  default <- set_hyperPriors()
  absent <- model_classes$class[!class_in_model(discrepancy)]
  for (cls in absent) {
    g <- !mapply(identical, hypers[[cls]], default[[cls]])
    if (any(g)) {
      given <- sprintf("`%s%s`", cls, c("Dist", "Init", "P1", "P2")[g])
      cli::cli_warn(c(
        sprintf("`discrepancy = \"%s\"` %s: %s of `hypers` %s ignored.", discrepancy,
                discrepancy_lacks(cls, discrepancy), paste(given, collapse = ", "),
                if (length(given) > 1L) "are" else "is"),
        i = discrepancy_having(cls)
      ), call = call)
    }
  }
  hypers[absent] <- list(NULL)
  hypers
}

# The columns of phi (the sampler's parameter vector, param_names()) that
# Phi holds: all but the classes these correlation families do not have
# (absent_classes()).
phi_columns <- function(spec) {
  mc <- spec$model
  keep <- !spec$classes %in% absent_classes(mc$kernS, mc$kernB)
  keep[indicator_positions(mc)] <- FALSE
  which(keep)
}

# The positions in phi of the indicator columns' thetaS, alphaS, thetaB and
# alphaB, held at 0 and 2 (indicator_hypers()): the levels' correlation is
# rhoS's and rhoB's, and Phi leaves them out.
indicator_positions <- function(model) {
  lv <- model$levels
  out <- model$outputs  # independent outputs: the output's columns, per output
  if (is.null(lv) && is.null(out)) return(integer(0))
  pos <- unlist(Map(function(c, n) c + seq_len(n) - 1L, c(lv$col, out$col), c(lv$ncol, out$ncol)))
  K <- output_count(model)
  unlist(lapply(c("thetaS", "alphaS", "thetaB", "alphaB"), function(cls) {
    n <- model$length[[cls]] %/% K
    if (n == 0L) integer(0) else model$offset[[cls]] + rep((seq_len(K) - 1L) * n, each = length(pos)) + pos
  }))
}

# For each parameter class, the columns of Phi holding it (integer(0) for a
# smoothness that is not sampled).
phi_indices <- function(spec) {
  cls <- spec$classes[phi_columns(spec)]
  stats::setNames(lapply(param_classes, function(k) which(cls == k)), param_classes)
}

# The prior table and classes of Phi's columns.
phi_spec <- function(fit) {
  cols <- phi_columns(fit$model$spec)
  list(table = fit$model$spec$table[cols, , drop = FALSE], classes = fit$model$spec$classes[cols],
       cols = cols)
}

# Rows `rows` of fit$Phi as full parameter vectors on the sampler's scale
# (kappa on [0, 1], the columns Phi leaves out at their fixed values): what
# the compiled entry points take. Every path from draws to the compiled code
# (predict(), the checks, the conflict check) goes through here.
sampler_draws <- function(fit, rows = seq_len(nrow(fit$Phi))) {
  spec <- fit$model$spec
  out <- matrix(spec$init, length(rows), length(spec$init), byrow = TRUE)
  out[, phi_columns(spec)] <- sampler_scale(fit$Phi[rows, , drop = FALSE], fit$model$scale)
  out
}

# Expands every class to one row per parameter: the C++ prior table, the
# initial values on the sampler's scale and the initial proposal SDs. The
# classes without parameters under `discrepancy` have no prior. The
# compiled model description (`model`, compiled_model()) is the caller's to
# add: it needs the kernels, the algebra and the data (build_model()).
# With independent outputs (`outputs`: the output's list(col, ncol, L),
# `levels` without it) each perOutput class's priors are one output's,
# repeated for every output. With the simulator's own noise (`replicates`:
# list(count, ssw), R/sim_noise.R) sigma2R has a parameter.
build_priors <- function(kappaSpec, hypers, scale, p, q, discrepancy = "gp", noise = 1L,
                         levels = NULL, source = NULL, outputs = NULL, emulator = TRUE,
                         replicates = NULL, call = parent.frame()) {
  nLev <- level_count(levels)
  nSrc <- source_count(source)
  K <- output_count(outputs)
  nRep <- noise_sizes(replicates)
  asked <- asked_classes(hypers)
  sizes <- class_sizes(p, q, discrepancy, noise, nLev, nSrc, emulator = emulator,
                       replicates = nRep, asked = asked)
  classes <- param_classes[sizes > 0L]
  priors <- list(kappa = kappaSpec)
  for (cls in classes[-1]) {
    priors[[cls]] <- check_class_spec(hypers[[cls]], cls, sizes[[cls]], call = call)
    if (K > 1L && model_classes$perOutput[match(cls, model_classes$class)]) {
      priors[[cls]] <- lapply(priors[[cls]], rep, times = K)
    }
  }
  cal <- p + seq_len(q)
  lo <- scale$xmin[cal]
  rng <- scale$xmax[cal] - scale$xmin[cal]
  # kappa: initial value (native units) and prior support
  for (j in seq_len(q)) {
    s <- priors$kappa
    if (is.na(s$init[j])) {
      mid <- lo[j] + rng[j] / 2
      inside <- s$dist[j] %in% c("beta", "fixed") ||
        is.finite(.log_prior(mid, prior_families[[s$dist[j]]], s$p1[j], s$p2[j]))
      if (s$dist[j] == "fixed") {
        cli::cli_abort("{.arg kappaInit} must be given when {.arg kappaDist} is {.val fixed}.", call = call)
      }
      priors$kappa$init[j] <- if (inside) mid else prior_center(s$dist[j], s$p1[j], s$p2[j])
    } else if (s$dist[j] != "fixed") {
      u <- if (s$dist[j] == "beta") (s$init[j] - lo[j]) / rng[j] else s$init[j]
      if (!is.finite(.log_prior(u, prior_families[[s$dist[j]]], s$p1[j], s$p2[j]))) {
        cli::cli_abort(
          "{.arg kappaInit} = {s$init[j]} lies outside the support of its {.val {s$dist[j]}} prior.",
          call = call
        )
      }
    }
  }
  for (cls in classes[-1]) {
    s <- priors[[cls]]
    miss <- is.na(s$init)
    priors[[cls]]$init[miss] <- as.numeric(unlist(Map(prior_center, s$dist[miss], s$p1[miss], s$p2[miss])))
  }

  rows <- list()
  init <- numeric(0)
  for (cls in classes) {
    s <- priors[[cls]]
    for (j in seq_along(s$dist)) {
      if (cls == "kappa") {
        stretched <- s$dist[j] == "beta"
        rows[[length(rows) + 1]] <- prior_row(
          s$dist[j], s$p1[j], s$p2[j], cls,
          a = if (stretched) 0 else lo[j], b = if (stretched) 1 else rng[j],
          lconst = if (stretched) -log(rng[j]) else 0
        )
        init <- c(init, (s$init[j] - lo[j]) / rng[j])
      } else {
        rows[[length(rows) + 1]] <- prior_row(s$dist[j], s$p1[j], s$p2[j], cls)
        init <- c(init, s$init[j])
      }
    }
  }
  table <- do.call(rbind, rows)
  vars <- param_names(p, q, discrepancy, noise, nLev, nSrc,
                      outputs = if (K > 1L) scale$output$levels else 1L, emulator = emulator,
                      replicates = nRep, asked = asked)
  cls_of <- param_class_of(p, q, discrepancy, noise, nLev, nSrc, outputs = K, emulator = emulator,
                           replicates = nRep, asked = asked)
  sd0 <- model_classes$sd0[match(cls_of, model_classes$class)]
  list(table = table, init = init, logsd = log(sd0), vars = vars,
       classes = cls_of, outputOf = if (K > 1L) param_output_of(p, q, discrepancy, noise, nLev, nSrc, K, asked),
       priors = priors, fns = prior_functions(table, vars, cls_of, scale))
}

# One log-density function per parameter, in the units it is reported in.
prior_functions <- function(table, vars, classes, scale) {
  fns <- lapply(seq_len(nrow(table)), function(i) {
    r <- table[i, ]
    if (classes[i] == "kappa") {
      j <- which(vars[classes == "kappa"] == vars[i])
      lo <- scale$xmin[scale$p + j]
      rng <- scale$xmax[scale$p + j] - lo
      # kappa is reported natively; the sampler's argument is a + b * (kappa - lo) / rng
      function(x) .log_prior(r$a + r$b * (x - lo) / rng, r$family, r$p1, r$p2) + r$lconst
    } else {
      function(x) .log_prior(as.numeric(x), r$family, r$p1, r$p2)
    }
  })
  stats::setNames(fns, vars)
}
