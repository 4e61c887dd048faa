#' Correlation families
#'
#' Correlation between the rows of `X` and the rows of `Y` (or of `X` with
#' itself) under one of the separable families the two GPs of the
#' calibration model use (chosen by `kernelS` and `kernelB` in
#' [calibrate()]):
#' \deqn{R(x, y) = \prod_k r(d_k), \quad d_k = |x_k - y_k|, \quad
#'   h_k = \sqrt{\theta_k}\, d_k,}
#' with, by `kernel`:
#' * `"powexp"`, the power exponential (the default, the vignette's):
#'   \eqn{r = \exp(-\theta d^{\alpha})}, smoothness \eqn{\alpha};
#' * `"gaussian"`: \eqn{r = \exp(-\theta d^2)}, the power exponential with
#'   \eqn{\alpha = 2} (infinitely differentiable sample paths);
#' * `"matern32"`, Matérn with \eqn{\nu = 3/2}:
#'   \eqn{r = (1 + \sqrt{3} h) \exp(-\sqrt{3} h)} (once differentiable);
#' * `"matern52"`, Matérn with \eqn{\nu = 5/2}:
#'   \eqn{r = (1 + \sqrt{5} h + 5 h^2 / 3) \exp(-\sqrt{5} h)} (twice
#'   differentiable).
#'
#' Near \eqn{d = 0} the last three are \eqn{1 - c\,\theta d^2 + \dots} with
#' \eqn{c = 1, 3/2, 5/6}: \eqn{\theta} has the same meaning (an inverse
#' squared length scale) in every family, so the default prior on
#' \eqn{\theta} of [set_hyperPriors()] suits them all. Only the power
#' exponential has a smoothness parameter \eqn{\alpha}; it is rough
#' (non-differentiable sample paths) for \eqn{\alpha < 2}, and at
#' \eqn{\alpha = 2} with a tiny nugget its correlation matrices are badly
#' conditioned, which is where the Matérn families help.
#'
#' @param X Numeric matrix (rows are points). A vector is taken as one column.
#' @param Y Optional numeric matrix with the same number of columns as `X`;
#'   `NULL` (default) means `X`.
#' @param theta Scale parameters, positive: one per column, or a scalar used
#'   for every column.
#' @param alpha Smoothness parameters of the power exponential; the model
#'   uses `[1, 2]`, and any value in `(0, 2]` gives a valid correlation: one
#'   per column, or a scalar. Not used by the other families (a warning if
#'   given).
#' @param kernel The family: `"powexp"` (default), `"gaussian"`,
#'   `"matern32"` or `"matern52"`.
#' @return A `nrow(X)` by `nrow(Y)` matrix.
#' @export
#' @examples
#' X  <- matrix(c(1, 3, 5,
#'                2, 2, 6,
#'                1, 4, 1), nrow = 3, byrow = TRUE)
#' Y  <- matrix(c(7, 3, 0,
#'                2, 2, 4), nrow = 2, byrow = TRUE)
#' sc <- c(1, 2, 3) # scale parameters
#' sm <- c(2, 1, 2) # smoothness parameters
#' round(correlation(X, theta = sc, alpha = sm), 5)
#' round(correlation(X, Y, theta = sc, alpha = sm), 5)
#' # the same scales under the Matern 5/2 family
#' round(correlation(X, theta = sc, kernel = "matern52"), 5)
#' # one input: the four families against the distance
#' d <- seq(0, 1, by = 0.25)
#' sapply(c("powexp", "gaussian", "matern32", "matern52"), function(k)
#'   correlation(d, 0, theta = 4, alpha = 1.5, kernel = k)[, 1])
correlation <- function(X, Y = NULL, theta, alpha = NULL, kernel = "powexp") {
  kernel <- check_kernel(kernel, "kernel")
  X <- check_input_matrix(X, "X")
  Y <- if (is.null(Y)) X else check_input_matrix(Y, "Y")
  if (ncol(Y) != ncol(X)) {
    cli::cli_abort(
      "{.arg X} and {.arg Y} must have the same number of columns (got {ncol(X)} and {ncol(Y)})."
    )
  }
  k <- ncol(X)
  theta <- check_length(theta, k, "theta", "column of X")
  if (!is.numeric(theta) || any(!is.finite(theta)) || any(theta < 0)) {
    cli::cli_abort("{.arg theta} must be non-negative and finite.")
  }
  if (kernel_has_alpha(kernel)) {
    if (is.null(alpha)) {
      cli::cli_abort("{.arg alpha} must be given for the {.val {kernel}} family (its smoothness, in (0, 2]).")
    }
    alpha <- check_length(alpha, k, "alpha", "column of X")
    if (!is.numeric(alpha) || any(!is.finite(alpha)) || any(alpha <= 0 | alpha > 2)) {
      cli::cli_abort("{.arg alpha} must lie in (0, 2].")
    }
  } else {
    if (!is.null(alpha)) {
      cli::cli_warn("{.arg alpha} is not used: the {.val {kernel}} family has no smoothness parameter.")
    }
    alpha <- rep(2, k)
  }
  .corr_matrix(X, Y, as.numeric(theta), as.numeric(alpha), kernel_codes[[kernel]])
}

# The correlation families, one row each: name, code (its struct in
# src/kernels.cpp holds the same; checked at load), label (for print()) and
# whether it has a smoothness parameter alpha (class alphaS/alphaB).
kernels <- rows_table(
  list(name = "powexp", code = 1L, label = "power exponential", alpha = TRUE),
  list(name = "gaussian", code = 2L, label = "Gaussian", alpha = FALSE),
  list(name = "matern32", code = 3L, label = "Matern 3/2", alpha = FALSE),
  list(name = "matern52", code = 4L, label = "Matern 5/2", alpha = FALSE)
)
kernel_codes <- stats::setNames(kernels$code, kernels$name)

# The name of a family given by name or code.
kernel_name <- function(kernel) {
  if (is.numeric(kernel)) names(kernel_codes)[match(kernel, kernel_codes)] else kernel
}

# Does the family have a smoothness parameter alpha? (Name or code.)
kernel_has_alpha <- function(kernel) isTRUE(kernels$alpha[match(kernel_name(kernel), kernels$name)])

# A family name, checked.
check_kernel <- function(kernel, arg, call = parent.frame()) {
  if (!is.character(kernel) || length(kernel) != 1L || is.na(kernel) ||
      !kernel %in% names(kernel_codes)) {
    cli::cli_abort(
      "{.arg {arg}} must be one of {.or {.val {names(kernel_codes)}}}, not {format_choice(kernel)}.",
      call = call
    )
  }
  kernel
}

check_input_matrix <- function(x, arg, call = parent.frame()) {
  if (is.data.frame(x)) x <- as.matrix(x)
  if (is.null(dim(x)) && is.numeric(x)) x <- matrix(x, ncol = 1)
  if (!is.matrix(x) || !is.numeric(x)) {
    cli::cli_abort("{.arg {arg}} must be a numeric matrix, not {.obj_type_friendly {x}}.", call = call)
  }
  if (any(!is.finite(x))) {
    cli::cli_abort("{.arg {arg}} must not contain NA, NaN or infinite values.", call = call)
  }
  storage.mode(x) <- "double"
  x
}
