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
# the pages a user meets first, rendered by a real browser (headless
# Chromium, when installed): each must render its title, and the home
# page's screenshot goes to docs/home.png
browser <- Sys.which(c("chromium", "chromium-browser", "google-chrome"))
browser <- browser[nzchar(browser)][1]
unrendered <- character()
if (!is.na(browser)) {
  pages <- c("docs/index.html", "docs/reference/index.html", "docs/reference/calibrate.html",
             list.files("docs/articles", pattern = "\\.html$", full.names = TRUE))
  flags <- c("--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars")
  for (f in pages) {
    url <- paste0("file://", normalizePath(f))
    dom <- suppressWarnings(system2(browser, c(flags, "--dump-dom", url), stdout = TRUE, stderr = FALSE))
    if (!any(grepl("<h1", dom)) || any(grepl("Error in |## Error", dom))) unrendered <- c(unrendered, f)
  }
  system2(browser, c(flags, "--window-size=1280,1600", "--screenshot=docs/home.png",
                     paste0("file://", normalizePath("docs/index.html"))), stdout = FALSE, stderr = FALSE)
  cat(sprintf("\nBrowser (%s): %d of %d pages rendered; home page screenshot in docs/home.png\n",
              basename(browser), length(pages) - length(unrendered), length(pages)))
  if (length(unrendered)) cat(unrendered, sep = "\n")
}
cat(sprintf("\nSite: %d pages in %s; %d broken internal links; %d pages with an R error\n",
            length(files), normalizePath("docs"), length(broken), length(errors)))
if (length(broken)) cat(broken, sep = "\n")
if (length(errors)) cat(errors, sep = "\n")
quit(status = if (length(broken) || length(errors) || length(unrendered)) 1 else 0)
