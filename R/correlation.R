#' Power-exponential correlation
#'
#' Correlation between the rows of `X` and the rows of `Y` (or of `X` with
#' itself) under the separable power-exponential family used by both GPs of
#' the calibration model:
#' \deqn{R(x, y) = \prod_k \exp(-\theta_k |x_k - y_k|^{\alpha_k}).}
#'
#' @param X Numeric matrix (rows are points). A vector is taken as one column.
#' @param Y Optional numeric matrix with the same number of columns as `X`;
#'   `NULL` (default) means `X`.
#' @param theta Scale parameters, positive: one per column, or a scalar used
#'   for every column.
#' @param alpha Smoothness parameters; the model uses `[1, 2]`, and any value in
#'   `(0, 2]` gives a valid correlation: one per column, or a scalar.
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
correlation <- function(X, Y = NULL, theta, alpha) {
  X <- check_input_matrix(X, "X")
  Y <- if (is.null(Y)) X else check_input_matrix(Y, "Y")
  if (ncol(Y) != ncol(X)) {
    cli::cli_abort(
      "{.arg X} and {.arg Y} must have the same number of columns (got {ncol(X)} and {ncol(Y)})."
    )
  }
  k <- ncol(X)
  theta <- check_length(theta, k, "theta", "column of X")
  alpha <- check_length(alpha, k, "alpha", "column of X")
  if (!is.numeric(theta) || any(!is.finite(theta)) || any(theta < 0)) {
    cli::cli_abort("{.arg theta} must be non-negative and finite.")
  }
  if (!is.numeric(alpha) || any(!is.finite(alpha)) || any(alpha <= 0 | alpha > 2)) {
    cli::cli_abort("{.arg alpha} must lie in (0, 2].")
  }
  .corr_matrix(X, Y, as.numeric(theta), as.numeric(alpha))
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
