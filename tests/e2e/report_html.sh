#!/usr/bin/env bash
# End to end: a fixture run -> `photonbench report` -> index.html opened in headless Chromium, which
# must show no console or resource errors and load every image. Chromium missing is a FAILURE, not a
# skip: CI must not pass without having looked at the page (scripts/setup.sh installs chromium).
# Args: $1 photonbench executable, $2 source dir.
set -euo pipefail
pb="${1:?usage: report_html.sh PHOTONBENCH SOURCE_DIR}"
src="${2:?usage: report_html.sh PHOTONBENCH SOURCE_DIR}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

browser="$(command -v chromium || command -v chromium-browser || true)"
if [ -z "$browser" ]; then
  echo "FAIL: chromium is not installed (apt-get install chromium; it is listed in scripts/setup.sh)"
  exit 1
fi

/usr/bin/python3 "$src/tools/tests/fixture.py" "$tmp/run" --seed 5 > /dev/null
"$pb" report "$tmp/run" --crop 20,30,24,12
report="$tmp/run/report"
[ -f "$report/index.html" ] || { echo "FAIL: no index.html"; exit 1; }

# A copy of the page, beside it (same relative paths), with a probe first in <head>: it records
# script errors and failed resource loads (capturing 'error' events), console.error calls, and after
# 'load' whether every <img> is complete with a natural width, into <pre id="pb-check"> for --dump-dom.
/usr/bin/python3 - "$report" <<'PY'
import sys, os
report = sys.argv[1]
probe = """<script>
(function () {
  var errors = [];
  window.addEventListener('error', function (e) {
    var t = e.target;
    errors.push(t && t !== window ? 'failed to load ' + (t.currentSrc || t.src || t.href || t.tagName)
                                  : 'script error: ' + e.message);
  }, true);
  var consoleError = console.error;
  console.error = function () {
    errors.push('console.error: ' + Array.prototype.join.call(arguments, ' '));
    consoleError.apply(console, arguments);
  };
  window.addEventListener('load', function () {
    var imgs = Array.prototype.slice.call(document.images);
    var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); })
                     .map(function (i) { return i.getAttribute('src'); });
    var pre = document.createElement('pre');
    pre.id = 'pb-check';
    // The image viewer's panels are made by its script: the rest must be the page's own <img>s.
    var own = imgs.filter(function (i) { return !i.closest('.viewer-stage'); }).length;
    pre.textContent = JSON.stringify({images: own, viewer_images: imgs.length - own, broken: broken,
                                      errors: errors});
    document.body.appendChild(pre);
  });
})();
</script>"""
with open(os.path.join(report, "index.html"), encoding="utf-8") as f:
    page = f.read()
assert "<head>" in page
with open(os.path.join(report, "pb-check.html"), "w", encoding="utf-8") as f:
    f.write(page.replace("<head>", "<head>" + probe, 1))
PY

set +e
timeout 180 "$browser" --headless --no-sandbox --disable-gpu --disable-background-networking \
  --disable-component-update --disable-sync --no-first-run --user-data-dir="$tmp/profile" \
  --enable-logging=stderr --v=0 --virtual-time-budget=15000 \
  --dump-dom "file://$report/pb-check.html" > "$tmp/dom.html" 2> "$tmp/chromium.log"
rc=$?
set -e
if [ $rc -ne 0 ]; then
  echo "FAIL: chromium exited $rc"; tail -20 "$tmp/chromium.log"; exit 1
fi

/usr/bin/python3 - "$tmp/dom.html" "$report/index.html" "$tmp/chromium.log" <<'PY'
import html, json, re, sys
dom = open(sys.argv[1], encoding="utf-8").read()
page = open(sys.argv[2], encoding="utf-8").read()
log = open(sys.argv[3], encoding="utf-8", errors="replace").read()
m = re.search(r'<pre id="pb-check">(.*?)</pre>', dom, re.S)
if not m:
    sys.exit("FAIL: the page's load event never ran (no probe result in the DOM)")
result = json.loads(html.unescape(m.group(1)))
expected = len(re.findall(r"<img\b", page))
problems = []
if result["images"] != expected:
    problems.append(f"{result['images']} images in the DOM, {expected} in index.html")
if result["broken"]:
    problems.append("images not loaded: " + ", ".join(result["broken"]))
if result["errors"]:
    problems.append("page errors: " + "; ".join(result["errors"]))
# Chromium's own log of the page's console (CONSOLE lines) and of blocked/failed loads.
for line in log.splitlines():
    if re.search(r"CONSOLE|Uncaught|Failed to load resource|Not allowed to load local resource", line):
        problems.append("chromium log: " + line.strip())
if problems:
    print("FAIL:\n  " + "\n  ".join(problems))
    sys.exit(1)
if result.get("viewer_images", 0) == 0 and 'class="viewer"' in page:
    sys.exit("FAIL: the image viewer's script made no panels")
print(f"ok: {result['images']} images and {result['viewer_images']} in the viewers loaded, "
      "no console errors")
PY
