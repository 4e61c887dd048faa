#' Mode of a continuous sample
#'
#' Estimates the mode of a continuous distribution from a sample, like a
#' histogram: the range of `x` is cut into equal-width bins and the mean of
#' the draws in the most populated bin is returned.
#'
#' @param x Numeric vector (draws).
#' @param breaks Number of bins. `NULL` (default) chooses it from the sample
#'   size and spread (Freedman-Diaconis rule, [grDevices::nclass.FD()]).
#' @return A single number: the value itself when all the finite values
#'   are equal (one value included).
#' @export
#' @examples
#' set.seed(1)
#' vec <- runif(100, 0, 10)
#' pmode(vec)
#' pmode(vec, breaks = 10)
#' pmode(rnorm(1e4, mean = 3))
pmode <- function(x, breaks = NULL) {
  if (!is.numeric(x) || length(x) == 0L) {
    cli::cli_abort("{.arg x} must be a non-empty numeric vector.")
  }
  x <- x[is.finite(x)]
  if (length(x) == 0L) cli::cli_abort("{.arg x} has no finite values.")
  if (!is.null(breaks)) breaks <- check_count(breaks, "breaks")
  # one value (or all equal): the mode, before nclass.FD() sees no spread
  r <- range(x)
  if (r[1] == r[2]) return(r[1])
  if (is.null(breaks)) breaks <- max(1L, grDevices::nclass.FD(x))
  bin <- pmin(floor((x - r[1]) / (r[2] - r[1]) * breaks), breaks - 1) + 1
  counts <- tabulate(bin, nbins = breaks)
  mean(x[bin == which.max(counts)])
}
