# blas_kind() classifies the library path R reports (extSoftVersion()); the
# hint for large calibrations on the reference BLAS is shown once a session.

test_that("blas_kind() tells the reference BLAS from optimized ones", {
  expect_identical(blas_kind("/usr/lib/x86_64-linux-gnu/blas/libblas.so.3.11.0"), "reference")
  expect_identical(blas_kind("/usr/lib/R/lib/libRblas.so"), "reference")
  expect_identical(blas_kind("/usr/lib/x86_64-linux-gnu/openblas-pthread/libblas.so.3"), "optimized")
  expect_identical(blas_kind("/opt/intel/mkl/lib/libmkl_rt.so"), "optimized")
  expect_identical(blas_kind("/usr/lib/x86_64-linux-gnu/libflexiblas.so.3"), "optimized")
  expect_identical(blas_kind(""), "unknown")
  expect_identical(blas_kind(NA_character_), "unknown")
  expect_true(blas_kind() %in% c("reference", "optimized", "unknown"))
})

test_that("the BLAS hint is shown once per session, for m >= 500 on the reference BLAS", {
  old <- fbc_session$blasHint
  on.exit(fbc_session$blasHint <- old)
  fbc_session$blasHint <- FALSE
  expect_silent(blas_hint(499, kind = "reference"))
  expect_silent(blas_hint(2000, kind = "optimized"))
  expect_snapshot(blas_hint(1000, kind = "reference"))
  expect_silent(blas_hint(1000, kind = "reference"))  # only once
})
