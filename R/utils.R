# Small helpers used throughout.

`%||%` <- function(x, y) if (is.null(x)) y else x
