# Small helpers used throughout.

`%||%` <- function(x, y) if (is.null(x)) y else x

# One string per row of the numeric matrix X, equal exactly for identical
# rows (17 significant digits): the key that groups identical inputs.
row_keys <- function(X) {
  apply(X, 1, function(r) paste(format(r, digits = 17), collapse = "\r"))
}
