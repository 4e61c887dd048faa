# Builds the package's web site (pkgdown) into docs/: the home page from
# README.md, the reference grouped by task (_pkgdown.yml), the articles
# (vignettes/) and NEWS. Installs what is missing and FBC itself first, so
# that every example and article runs against this checkout. The site is
# built, not deployed. Run from the package root: Rscript tools/site.R
source("tools/deps.R")
if (!requireNamespace("pkgdown", quietly = TRUE)) {
  install.packages("pkgdown")
}
Sys.setenv(NOT_CRAN = "true")
pkgdown::build_site(pkg = ".", install = FALSE, new_process = FALSE, preview = FALSE)
# every internal link of the built site must resolve to a file
files <- list.files("docs", pattern = "\\.html$", recursive = TRUE, full.names = TRUE)
broken <- character()
for (f in files) {
  html <- paste(readLines(f, warn = FALSE), collapse = "\n")
  links <- regmatches(html, gregexpr('href="[^"#]+', html))[[1]]
  links <- sub('^href="', "", links)
  links <- links[!grepl("^(https?:|mailto:|javascript:|data:)", links)]
  for (l in unique(links)) {
    # a file:// link (a local copy of MathJax) must exist where it points
    target <- if (startsWith(l, "file://")) sub("^file://", "", l) else
      file.path(dirname(f), utils::URLdecode(l))
    if (!file.exists(target)) broken <- c(broken, sprintf("%s -> %s", f, l))
  }
}
errors <- character()
for (f in files) {
  html <- readLines(f, warn = FALSE)
  hit <- grep("## Error|Error in |Error:", html, value = TRUE)
  if (length(hit)) errors <- c(errors, sprintf("%s: %s", f, trimws(hit[1])))
}
cat(sprintf("\nSite: %d pages in %s; %d broken internal links; %d pages with an R error\n",
            length(files), normalizePath("docs"), length(broken), length(errors)))
if (length(broken)) cat(broken, sep = "\n")
if (length(errors)) cat(errors, sep = "\n")
quit(status = if (length(broken) || length(errors)) 1 else 0)
