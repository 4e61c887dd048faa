# Which BLAS R runs on, and a hint (once per session) when a large
# calibration runs on the reference BLAS.

# "reference", "optimized" or "unknown", from the path of the BLAS library
# R loaded (extSoftVersion()); `path` is for tests.
blas_kind <- function(path = extSoftVersion()[["BLAS"]]) {
  if (!is.character(path) || length(path) != 1L || is.na(path) || !nzchar(path)) {
    return("unknown")
  }
  p <- tolower(path)
  if (grepl("openblas|mkl|blis|atlas|accelerate|veclib|flexiblas|armpl|libsci", p)) {
    return("optimized")
  }
  # R's own (libRblas) and the Netlib reference (Debian: .../blas/libblas.so.3)
  if (grepl("librblas|/blas/libblas|^libblas", p) || grepl("/libblas\\.so", p)) {
    return("reference")
  }
  "unknown"
}

fbc_session <- new.env(parent = emptyenv())
fbc_session$blasHint <- FALSE

# Says once per session, for m >= 500 simulator runs on the dense algebra
# and the reference BLAS, how much faster an optimized BLAS would make the
# run (the Kronecker and nearest-neighbour algebras factor no m x m block).
blas_hint <- function(m, kind = blas_kind()) {
  if (m < 500L || kind != "reference" || isTRUE(fbc_session$blasHint)) return(invisible(FALSE))
  fbc_session$blasHint <- TRUE
  cli::cli_inform(c(
    "i" = "R is using the reference BLAS: with {m} simulator runs, an optimized BLAS makes each factorisation about 9 times faster (measured at m = 1000, see the README's speed section).",
    " " = "On Debian or Ubuntu: {.code sudo apt-get install libopenblas0-pthread} (R picks it up at its next start); elsewhere see the R Installation and Administration manual, section {.emph BLAS}.",
    " " = "This message is shown once per session."
  ))
  invisible(TRUE)
}
