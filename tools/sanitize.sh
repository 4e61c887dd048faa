#!/usr/bin/env bash
# Builds FBC with AddressSanitizer and UndefinedBehaviorSanitizer into a
# library of its own and runs the test suite against that build. Any report
# of the sanitizers is printed at the end (and the exit status is 1).
# Usage, from the package root:  tools/sanitize.sh [library directory]
# FBC_SLOW=true also runs the slow tier. Needs gcc's libasan and libubsan.
set -euo pipefail
cd "$(dirname "$0")/.."
lib="${1:-${TMPDIR:-/tmp}/fbc-sanitize-lib}"
mkdir -p "$lib"
mk="$(mktemp)"
cat > "$mk" <<'MK'
CXXFLAGS = -g -O1 -fno-omit-frame-pointer -fsanitize=address,undefined
CXX11FLAGS = $(CXXFLAGS)
CXX14FLAGS = $(CXXFLAGS)
CXX17FLAGS = $(CXXFLAGS)
LDFLAGS = -fsanitize=address,undefined
MK
R_MAKEVARS_USER="$mk" R CMD INSTALL --preclean --no-multiarch --no-test-load -l "$lib" .
rm -f "$mk"
pre="$(gcc -print-file-name=libasan.so):$(gcc -print-file-name=libubsan.so)"
log="$(mktemp)"
# R itself leaks by design at exit: leak reports are off; every other
# report stops the process that made it and is kept in the log.
set +e
LD_PRELOAD="$pre" ASAN_OPTIONS="detect_leaks=0:halt_on_error=0" \
  UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=0" \
  R_LIBS="$lib${R_LIBS:+:$R_LIBS}" NOT_CRAN=true \
  Rscript -e 'res <- testthat::test_dir("tests/testthat", package = "FBC",
                load_package = "installed", stop_on_failure = FALSE,
                reporter = testthat::SummaryReporter$new(show_praise = FALSE))
              df <- as.data.frame(res)
              cat(sprintf("\n%d passed, %d failed\n", sum(df$passed),
                          sum(df$failed) + sum(df$error)))' 2>&1 | tee "$log"
set -e
n=$(grep -cE "ERROR: AddressSanitizer|runtime error:" "$log" || true)
echo "sanitizer reports: $n"
grep -E "ERROR: AddressSanitizer|runtime error:" "$log" | sort | uniq -c || true
rm -f "$log"
[ "$n" -eq 0 ]
