# Prior families: the registry, one entry per family, and their checks.

# One prior family. `code`: its code in the C++ core (PriorFamily in
# src/fbc.h, named by .prior_codes(); check_prior_codes() compares the two).
# `params`: what p1 and p2 mean (the table of prior_builder()); a parameter
# not named is unused. `need`: what each named parameter must be, "finite" or
# "positive"; `ordered`: p1 < p2 as well. `support(p1, p2)`: c(lower, upper).
# `cdf(x, p1, p2)`, `quantile(u, p1, p2)`: in the family's own units, NULL
# for a family that is not proper. `center(p1, p2)`: a value inside the
# support to start from when no initial value is given.
prior_entry <- function(code, params = character(), need = character(), ordered = FALSE,
                        support = function(p1, p2) c(-Inf, Inf), cdf = NULL,
                        quantile = NULL, center) {
  list(code = code, params = params, need = need, ordered = ordered, support = support,
       cdf = cdf, quantile = quantile, center = center, proper = !is.null(cdf))
}

positive_support <- function(p1, p2) c(0, Inf)

prior_registry <- list(
  uniform = prior_entry(1L,
    params = c(p1 = "lower bound", p2 = "upper bound"),
    need = c(p1 = "finite", p2 = "finite"), ordered = TRUE,
    support = function(p1, p2) c(p1, p2),
    cdf = function(x, p1, p2) stats::punif(x, p1, p2),
    quantile = function(u, p1, p2) stats::qunif(u, p1, p2),
    center = function(p1, p2) (p1 + p2) / 2),
  gaussian = prior_entry(2L,
    params = c(p1 = "mean", p2 = "standard deviation"),
    need = c(p1 = "finite", p2 = "positive"),
    cdf = function(x, p1, p2) stats::pnorm(x, p1, p2),
    quantile = function(u, p1, p2) stats::qnorm(u, p1, p2),
    center = function(p1, p2) p1),
  gamma = prior_entry(3L,
    params = c(p1 = "shape", p2 = "rate"),
    need = c(p1 = "positive", p2 = "positive"),
    support = positive_support,
    cdf = function(x, p1, p2) stats::pgamma(x, p1, rate = p2),
    quantile = function(u, p1, p2) stats::qgamma(u, p1, rate = p2),
    center = function(p1, p2) p1 / p2),
  beta = prior_entry(4L,
    params = c(p1 = "shape1", p2 = "shape2"),
    need = c(p1 = "positive", p2 = "positive"),
    support = function(p1, p2) c(0, 1),
    cdf = function(x, p1, p2) stats::pbeta(x, p1, p2),
    quantile = function(u, p1, p2) stats::qbeta(u, p1, p2),
    center = function(p1, p2) p1 / (p1 + p2)),
  lognormal = prior_entry(5L,
    params = c(p1 = "meanlog", p2 = "sdlog"),
    need = c(p1 = "finite", p2 = "positive"),
    support = positive_support,
    cdf = function(x, p1, p2) stats::plnorm(x, p1, p2),
    quantile = function(u, p1, p2) stats::qlnorm(u, p1, p2),
    center = function(p1, p2) exp(p1)),
  logistic = prior_entry(6L,
    params = c(p1 = "location", p2 = "scale"),
    need = c(p1 = "finite", p2 = "positive"),
    cdf = function(x, p1, p2) stats::plogis(x, p1, p2),
    quantile = function(u, p1, p2) stats::qlogis(u, p1, p2),
    center = function(p1, p2) p1),
  # a beta shifted to [1, 2]
  betashift = prior_entry(7L,
    params = c(p1 = "shape1", p2 = "shape2"),
    need = c(p1 = "positive", p2 = "positive"),
    support = function(p1, p2) c(1, 2),
    cdf = function(x, p1, p2) stats::pbeta(x - 1, p1, p2),
    quantile = function(u, p1, p2) 1 + stats::qbeta(u, p1, p2),
    center = function(p1, p2) 1 + p1 / (p1 + p2)),
  exponential = prior_entry(8L,
    params = c(p1 = "rate"), need = c(p1 = "positive"),
    support = positive_support,
    cdf = function(x, p1, p2) stats::pexp(x, p1),
    quantile = function(u, p1, p2) stats::qexp(u, p1),
    center = function(p1, p2) 1 / p1),
  # X ~ InvGamma(shape a, scale b)  <=>  1/X ~ Gamma(a, rate = b)
  inversegamma = prior_entry(9L,
    params = c(p1 = "shape", p2 = "scale"),
    need = c(p1 = "positive", p2 = "positive"),
    support = positive_support,
    cdf = function(x, p1, p2) stats::pgamma(p2 / x, p1, lower.tail = FALSE),
    quantile = function(u, p1, p2) p2 / stats::qgamma(1 - u, p1, rate = 1),
    center = function(p1, p2) p2 / (p1 + 1)),
  # density 1/x on x > 0, improper
  jeffreys = prior_entry(10L, support = positive_support, center = function(p1, p2) 1),
  # not sampled: kept at its initial value (log density 0)
  fixed = prior_entry(11L, center = function(p1, p2) NA_real_),
  # for a variance: its square root (the sd) is half-t with p1 degrees of
  # freedom and scale p2 (p1 = 1: half-Cauchy), weakly informative on the
  # scale a variance acts on (Gelman 2006)
  halft_sd = prior_entry(12L,
    params = c(p1 = "degrees of freedom", p2 = "scale of the sd"),
    need = c(p1 = "positive", p2 = "positive"),
    support = positive_support,
    cdf = function(x, p1, p2) 2 * stats::pt(sqrt(pmax(x, 0)) / p2, p1) - 1,
    quantile = function(u, p1, p2) (p2 * stats::qt((1 + u) / 2, p1))^2,
    center = function(p1, p2) p2^2)
)

# The codes by name, as the compiled core takes them.
prior_families <- vapply(prior_registry, `[[`, integer(1), "code")

# The family names of prior codes (a parameter table's `family` column).
prior_family_name <- function(code) names(prior_families)[match(code, prior_families)]

# The compiled core switches on the codes of the registry: they must agree
# with its table (`compiled`), name for name.
check_prior_codes <- function(compiled = .prior_codes()) {
  if (!identical(compiled, prior_families)) {
    both <- union(names(prior_families), names(compiled))
    differ <- both[!mapply(identical, prior_families[both], compiled[both])]
    cli::cli_abort(c(
      "The prior family codes of the registry (R/priors.R) and of the compiled core (src/priors.cpp) differ.",
      x = "They differ for {.val {differ}}."
    ))
  }
  invisible(TRUE)
}

# Support, cdf, quantile and center of a family (see prior_entry()); the
# cdf and quantile are NA for a family that is not proper.
family_support <- function(dist, p1, p2) prior_registry[[dist]]$support(p1, p2)
prior_cdf <- function(x, dist, p1, p2) {
  f <- prior_registry[[dist]]
  if (f$proper) f$cdf(x, p1, p2) else NA_real_
}
prior_quantile <- function(u, dist, p1, p2) {
  f <- prior_registry[[dist]]
  if (f$proper) f$quantile(u, p1, p2) else NA_real_
}
prior_center <- function(dist, p1, p2) prior_registry[[dist]]$center(p1, p2)

#' Build a log prior density
#'
#' Returns a vectorised function giving the log density of a prior family,
#' `-Inf` outside its support. The density is computed by the same compiled
#' code the sampler uses.
#'
#' | `prior` | `p1` | `p2` |
#' |---|---|---|
#' | `"uniform"` | lower bound | upper bound |
#' | `"gaussian"` | mean | standard deviation |
#' | `"gamma"` | shape | rate (as in [stats::dgamma()]) |
#' | `"beta"` | shape1 | shape2 |
#' | `"lognormal"` | meanlog | sdlog |
#' | `"logistic"` | location | scale |
#' | `"betashift"` | shape1 | shape2 (a beta shifted to `[1, 2]`) |
#' | `"exponential"` | rate | (unused) |
#' | `"inversegamma"` | shape | scale |
#' | `"jeffreys"` | (unused) | (unused); density `1/x` on `x > 0`, improper |
#' | `"fixed"` | (unused) | (unused); log density 0 |
#' | `"halft_sd"` | degrees of freedom | scale of the sd; for a variance \eqn{x}: \eqn{\sqrt{x}} is half-t (`p1 = 1`: half-Cauchy) |
#'
#' @param prior Name of the prior family (see the table).
#' @param p1,p2 Parameters of the family.
#' @return A function of one numeric vector returning the log densities.
#' @export
#' @examples
#' pr_fun <- prior_builder(prior = "beta", p1 = 2, p2 = 5)
#' round(exp(pr_fun(c(-1, 0, 0.1, 0.5, 0.9, 1, 2))), 3)
#'
#' pr_fun <- prior_builder(prior = "uniform", p1 = -10, p2 = 10)
#' round(exp(pr_fun(c(-11, -5, 0, 4, 10, 12))), 3)
prior_builder <- function(prior, p1 = NA, p2 = NA) {
  check_prior(prior, p1, p2, arg = "prior", parg = c("p1", "p2"))
  code <- prior_families[[prior]]
  p1 <- as.numeric(p1)
  p2 <- as.numeric(p2)
  function(x) .log_prior(as.numeric(x), code, p1, p2)
}

# Validates a family name and its parameters; `arg` names the argument.
check_prior <- function(dist, p1, p2, arg, parg = arg, call = parent.frame()) {
  if (!is.character(dist) || length(dist) != 1L || is.na(dist) ||
      !dist %in% names(prior_families)) {
    cli::cli_abort(c(
      "{.arg {arg}} must be one of {.or {.val {names(prior_families)}}}.",
      x = "Got {format_choice(dist)}."
    ), call = call)
  }
  f <- prior_registry[[dist]]
  given <- list(p1 = p1, p2 = p2)[names(f$need)]
  ok <- function(v, need) {
    is.numeric(v) && length(v) == 1L && is.finite(v) && (need == "finite" || v > 0)
  }
  if (!all(mapply(ok, given, f$need)) || (f$ordered && !(p1 < p2))) {
    cli::cli_abort(c(
      "Impossible parameters {.arg {parg}} for the {.val {dist}} prior: {prior_rule(dist)}.",
      x = "Got p1 = {format_value(p1)} and p2 = {format_value(p2)}."
    ), call = call)
  }
  invisible(TRUE)
}

# What a family's parameters must be, in the words of prior_builder()'s table:
# "p1 (shape) and p2 (rate) must be positive".
prior_rule <- function(dist) {
  f <- prior_registry[[dist]]
  what <- paste0(names(f$params), " (", f$params, ")")
  need <- unname(f$need)
  if (f$ordered) return(sprintf("%s must be below %s, both %s", what[1], what[2], need[1]))
  if (length(unique(need)) == 1L) return(sprintf("%s must be %s", paste(what, collapse = " and "), need[1]))
  sprintf("%s must be %s and %s %s", what[1], need[1], what[2], need[2])
}

# Does a family's support not depend on its parameters?
support_known <- function(dist) !anyNA(family_support(dist, NA_real_, NA_real_))

# Does the family's support fit inside the parameter class's domain?
check_support <- function(dist, p1, p2, cls, arg, call = parent.frame()) {
  domain <- class_domain[[cls]]
  if (dist == "fixed" || domain == "real") return(invisible(TRUE))
  lim <- domain_bounds(cls)
  inside <- function(s) s[1] >= lim[1] && s[2] <= lim[2]
  if (!inside(family_support(dist, p1, p2))) {
    # every family whose support fits, those whose support is their
    # parameters (the uniform) within the domain, and fixed
    known <- Filter(support_known, setdiff(names(prior_registry), "fixed"))
    fits <- Filter(function(d) inside(family_support(d, NA_real_, NA_real_)), known)
    within <- switch(domain, positive = "on [0, upper]", unit12 = "within [1, 2]",
                     corr = "within [-1, 1]")
    given <- paste(setdiff(names(prior_registry), c(known, "fixed")), within)
    allowed <- paste(paste(c(fits, given), collapse = ", "), "or fixed")
    what <- model_domains$what[match(domain, model_domains$domain)]
    cli::cli_abort(c(
      "The {.val {dist}} prior in {.arg {arg}} does not fit {.field {cls}}, which must be {what}.",
      i = "Use {allowed}."
    ), call = call)
  }
  invisible(TRUE)
}

#' Priors for the hyperparameters
#'
#' Sets the prior family (`*Dist`), initial value (`*Init`) and the two family
#' parameters (`*P1`, `*P2`) for each class of hyperparameter (vignette
#' Table 1). A scalar applies to every parameter of its class; a vector gives
#' one value per parameter and must have that length (`p + q` for `thetaS`,
#' `alphaS`; `p` for `thetaB`, `alphaB`). The families and their parameters
#' are those of [prior_builder()]; `"fixed"` keeps the parameter at its
#' initial value and does not sample it. All hyperparameters live on the
#' scaled space (inputs in `[0, 1]`, responses standardised; see
#' [calibrate()]).
#'
#' A class whose family is changed (say `thetaSDist = "lognormal"`) must be
#' given that family's parameters (`thetaSP1`, `thetaSP2`): the defaults
#' belong to the default family and are refused for another one, with a
#' message naming the arguments to give. Initial values are checked against
#' the new family's support.
#'
#' Defaults (vignette A.1 but the noise): correlation scales \eqn{\theta}
#' Gamma(1.1, rate 0.1); smoothness \eqn{\alpha} Beta(5, 2) shifted to `[1,
#' 2]`; the GP variances \eqn{\sigma^2_S}, \eqn{\sigma^2_B} inverse gamma
#' (shape 1.5, scale 1.5); the bias mean \eqn{\mu_b} Gaussian(0, 1); the
#' S-GaSP scale \eqn{\lambda_z} lognormal(log 20, 1.5); the levels' partial
#' correlations \eqn{\rho} uniform on `(-1, 1)`.
#'
#' The measurement error variance \eqn{\sigma^2_E} has a half-Cauchy prior
#' on its sd, `"halft_sd"` with 1 degree of freedom and scale 1 (the
#' standardised response's sd): flat near 0, so precise field data set the
#' noise, and with a heavy tail for noisy ones (Gelman 2006). The vignette's
#' inverse gamma (shape 1.5, scale 1.5) on the variance says the noise is
#' about as large as the signal: it puts almost no mass on an sd below a
#' tenth of the response's, and on precise field data it overstated the
#' noise and widened \eqn{\kappa}'s interval (measured:
#' `vignette("model", package = "FBC")`). The vignette's prior stays
#' available by name: `set_hyperPriors(sigma2EDist = "inversegamma",
#' sigma2EP1 = 1.5, sigma2EP2 = 1.5)`.
#'
#' @eval hyper_param_docs()
#' @return An object of class `fbc_hypers` to pass as `hypers` to [calibrate()].
#' @export
#' @examples
#' priors <- set_hyperPriors(thetaSDist = "beta", thetaSP1 = 2, thetaSP2 = 6,
#'                           thetaSInit = 0.5)
#' priors$thetaS
set_hyperPriors <- function() {
  env <- environment()
  defaults <- formals(sys.function())
  out <- list()
  # each class of class_priors, in the table's order (gR, the latent
  # log-variances, has the GP of muG, sigma2G, thetaG as its prior:
  # sim_noise_priors())
  for (cls in intersect(param_classes, names(class_priors))) {
    is_missing <- function(arg) eval(call("missing", as.name(paste0(cls, arg))), env)
    dist <- get(paste0(cls, "Dist"), env)
    # a class a user adds (model_classes' over "asked") is in the model only
    # when given a family
    if (is.null(dist)) {
      given <- paste0(cls, c("Init", "P1", "P2"))[!vapply(c("Init", "P1", "P2"), is_missing, logical(1))]
      if (length(given)) {
        cli::cli_abort(c("{.arg {given}} {?is/are} given, but not {.arg {cls}Dist}.",
                         i = "{.arg {cls}Dist}, a prior family, adds {.code {cls}} to the model; without one the model has no such parameter."),
                       call = env)
      }
      next
    }
    # a family that cannot fit the class is the first thing to say
    for (d in Filter(support_known, unique(dist[is.character(dist) & dist %in% names(prior_registry)]))) {
      check_support(d, NA, NA, cls, arg = paste0(cls, "Dist"), call = env)
    }
    check_family_switch(get(paste0(cls, "Dist"), env), defaults[[paste0(cls, "Dist")]],
                        is_missing("P1"), is_missing("P2"), cls, call = env)
    spec <- list(
      dist = get(paste0(cls, "Dist"), env), init = get(paste0(cls, "Init"), env),
      p1 = get(paste0(cls, "P1"), env), p2 = get(paste0(cls, "P2"), env)
    )
    check_class_spec(spec, cls, n = NULL, call = env)
    out[[cls]] <- spec
  }
  structure(out, class = "fbc_hypers")
}
# Its arguments, four per class of class_priors with their defaults
# (R/model-classes.R), and their help.
formals(set_hyperPriors) <- unlist(lapply(names(class_priors), function(cls) {
  stats::setNames(class_priors[[cls]]$prior, paste0(cls, c("Dist", "Init", "P1", "P2")))
}), recursive = FALSE)
hyper_param_docs <- function() {
  out <- character()
  for (cls in names(class_priors)) {
    args <- paste0(cls, c("Dist", "Init", "P1", "P2"), collapse = ",")
    help <- class_priors[[cls]]$help
    if (is.null(help)) {
      out[length(out)] <- sub("^@param (\\S+)", paste0("@param \\1,", args), out[length(out)])
    } else {
      out <- c(out, paste("@param", args, class_models_docs(paste(help, collapse = " "), cls)))
    }
  }
  out
}

#' @export
print.fbc_hypers <- function(x, ...) {
  check_dots_empty(..., fn = print.fbc_hypers, name = "print", cls = "fbc_hypers", action = "warn")
  cat("<fbc hyperparameter priors>\n")
  for (cls in names(x)) {
    s <- x[[cls]]
    n <- max(lengths(s))
    one <- vapply(seq_len(n), function(i) {
      at <- function(v) v[(i - 1L) %% length(v) + 1L]
      format_prior(at(s$dist), at(s$p1), at(s$p2), at(s$init))
    }, character(1))
    # one per input when they differ
    if (length(unique(one)) > 1L) one <- paste0("[", seq_len(n), "] ", one)
    cat(sprintf("  %-8s %s\n", cls, paste(unique(one), collapse = "; ")))
  }
  invisible(x)
}

# One prior as print.fbc_hypers() shows it: the family with the parameters it
# uses, named as in prior_builder()'s table (those of another family, left
# from the default, are not shown), and the initial value ("default": the
# family's centre); a fixed parameter by its value.
format_prior <- function(dist, p1, p2, init) {
  if (identical(dist, "fixed")) return(sprintf("fixed at %s", format(init)))
  f <- prior_registry[[dist]]
  vals <- c(p1 = p1, p2 = p2)[names(f$params)]
  fam <- if (length(vals)) sprintf("%s(%s)", dist, paste(f$params, vapply(vals, format, ""), collapse = ", ")) else dist
  sprintf("%s%s, init %s", fam, if (f$proper) "" else " (improper)",
          if (is.na(init)) "default" else format(init))
}

# A prior family switched away from its argument's default while the family
# parameters were left at their defaults (`missingP1`, `missingP2`): those
# belong to the default family and would silently mean something else (Beta's
# 1.1, 1.1 read as N(1.1, 1.1)). Refused, naming the arguments to give.
check_family_switch <- function(dist, default, missingP1, missingP2, prefix, units = NULL,
                                 call = parent.frame()) {
  if (!is.character(dist)) return(invisible(TRUE))
  for (d in unique(dist[!is.na(dist) & dist != default & dist %in% names(prior_registry)])) {
    need <- prior_registry[[d]]$params
    miss <- c(p1 = missingP1, p2 = missingP2)[names(need)]
    if (!any(miss)) next
    args <- paste0(prefix, toupper(names(need)))
    give <- paste0("`", args[miss], "` (", need[miss], ")")
    cli::cli_abort(c(
      "{.code {prefix}Dist = \"{d}\"} needs its own parameters: give {paste(give, collapse = ' and ')}{if (!is.null(units)) paste0(', in the units of ', units) else ''}.",
      i = "The defaults of {.arg {prefix}P1} and {.arg {prefix}P2} belong to the default {.val {default}} prior and mean something else for {.val {d}}.",
      i = "See {.help FBC::prior_builder} for each family's parameters."
    ), call = call)
  }
  invisible(TRUE)
}

# Checks one class's Dist/Init/P1/P2 (each of length 1 or `n` when n is
# known) and returns them recycled to length n.
check_class_spec <- function(spec, cls, n, call = parent.frame()) {
  args <- paste0(cls, c("Dist", "Init", "P1", "P2"))
  len <- lengths(spec)
  if (is.null(n)) {
    n_ <- max(len)
    if (any(!len %in% c(1L, n_))) {
      cli::cli_abort(
        "{.arg {args}} must have length 1 or a common length (got lengths {len}).",
        call = call
      )
    }
  } else {
    for (i in seq_along(spec)) spec[[i]] <- check_length(spec[[i]], n, args[i], paste(cls, "parameter"), call = call)
    n_ <- n
  }
  spec <- lapply(spec, rep_len, n_)
  if (!is.character(spec$dist)) {
    cli::cli_abort("{.arg {args[1]}} must be a character vector of prior family names.", call = call)
  }
  for (v in c("init", "p1", "p2")) {
    x <- spec[[v]]
    if (!is.numeric(x) && !all(is.na(x))) {
      cli::cli_abort("{.arg {args[match(v, c('dist', 'init', 'p1', 'p2'))]}} must be numeric.", call = call)
    }
    spec[[v]] <- as.numeric(x)
  }
  for (i in seq_len(n_)) {
    d <- spec$dist[i]
    check_prior(d, spec$p1[i], spec$p2[i], arg = args[1], parg = args[3:4], call = call)
    check_support(d, spec$p1[i], spec$p2[i], cls, arg = args[1], call = call)
    if (cls != "kappa") check_init(spec$init[i], d, spec$p1[i], spec$p2[i], cls, args[2], call)
  }
  spec
}

# An initial value must lie inside the parameter's domain (strictly, when the
# parameter is sampled on a log or logit scale) and inside its prior support.
check_init <- function(init, dist, p1, p2, cls, arg, call = parent.frame()) {
  if (is.na(init)) {
    if (dist == "fixed") {
      cli::cli_abort("{.arg {arg}} must be given when the prior is {.val fixed}.", call = call)
    }
    return(invisible(TRUE))
  }
  domain <- class_domain[[cls]]
  # a sampled parameter strictly inside its domain, a fixed one perhaps on
  # a bound
  b <- domain_bounds(cls)
  inside <- is.finite(init) &&
    if (dist == "fixed") init >= b[1] && init <= b[2] else init > b[1] && init < b[2]
  if (!inside) {
    what <- switch(domain, real = "finite", positive = "positive",
                   corr = if (dist == "fixed") "in [-1, 1]" else "strictly between -1 and 1",
                   unit12 = if (dist == "fixed") "in [1, 2]" else "strictly between 1 and 2")
    cli::cli_abort("{.arg {arg}} must be {what} (got {format_value(init)}).", call = call)
  }
  if (dist != "fixed" && !is.finite(.log_prior(init, prior_families[[dist]], p1, p2))) {
    cli::cli_abort(
      "{.arg {arg}} = {format_value(init)} lies outside the support of its {.val {dist}} prior.",
      call = call
    )
  }
  invisible(TRUE)
}

# Log prior and walk of one parameter: the prior argument is a + b * value
# (value on the sampler's scale), plus a constant so that logPost is the
# log density in the units the parameter is reported in.
prior_row <- function(dist, p1, p2, cls, a = 0, b = 1, lconst = 0) {
  data.frame(
    family = prior_families[[dist]], transform = class_transform[[cls]],
    p1 = if (is.na(p1)) 0 else p1, p2 = if (is.na(p2)) 0 else p2,
    a = a, b = b, lconst = lconst
  )
}
