#!/bin/sh
# Vendor the JavaScript that labkit's offline HTML reports embed, from npm (pinned versions):
#   mathjax@3.2.2                      es5/tex-svg-full.js   (TeX -> SVG, glyphs built in: no font files)
#   @jupyter-widgets/html-manager@1.0.15 dist/embed.js        (renders saved ipywidget state, ipywidgets 8)
# Output: labkit/reports/static/*.js.gz (committed; labkit.reports inlines them into every report,
# so a report never fetches anything at view time). Run this only to upgrade the pinned versions:
#   tools/vendor-assets.sh && git add labkit/reports/static
# Needs npm (Debian package `npm`) and network access to the npm registry.
set -eu
MATHJAX=mathjax@3.2.2
HTML_MANAGER=@jupyter-widgets/html-manager@1.0.15
here=$(cd "$(dirname "$0")/.." && pwd)
out="$here/labkit/reports/static"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
npm pack --silent "$MATHJAX" "$HTML_MANAGER" >/dev/null
mkdir mj hm
tar xzf mathjax-*.tgz -C mj
tar xzf jupyter-widgets-html-manager-*.tgz -C hm
mkdir -p "$out"
python3 - "$tmp" "$out" "$MATHJAX" "$HTML_MANAGER" <<'PY'
import base64, gzip, json, pathlib, re, sys

tmp, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
mathjax_pkg, manager_pkg = sys.argv[3], sys.argv[4]


def write(name, text):
    data = text.encode("utf-8")
    (out / (name + ".gz")).write_bytes(gzip.compress(data, 9, mtime=0))
    print(f"{name}: {len(data) / 1e6:.2f} MB ({len(gzip.compress(data, 9)) / 1e6:.2f} MB gzipped)")


def patch(text, old, new, count=1):
    if text.count(old) != count:
        sys.exit(f"vendor-assets: expected {count} occurrence(s) of {old[:60]!r}; the package changed, review the patch")
    return text.replace(old, new)


mathjax = (tmp / "mj/package/es5/tex-svg-full.js").read_text("utf-8")
write("mathjax-tex-svg-full.js", mathjax)

dist = tmp / "hm/package/dist"
embed = (dist / "embed.js").read_text("utf-8")
# 1. the bundle is inlined into the HTML, so webpack's automatic public path (from the script's
#    src) does not exist: fall back to "./" instead of throwing.
embed = patch(embed, 'if(!e)throw new Error("Automatic publicPath is not supported in this browser");', 'if(!e)e="./";')
# 2. icon fonts (Font Awesome): woff2 as data: URIs, other formats dropped (Chromium uses woff2).
def font(m):
    name = m.group(1)
    if name.endswith(".woff2"):
        b64 = base64.b64encode((dist / name).read_bytes()).decode("ascii")
        return f'e.exports="data:font/woff2;base64,{b64}"'
    return 'e.exports="data:,"'
embed, n = re.subn(r'e\.exports=n\.p\+"([0-9a-f]{20}\.(?:woff2|woff|ttf|eot|svg))"', font, embed)
if n != 15:
    sys.exit(f"vendor-assets: expected 15 font/image assets in embed.js, found {n}")
# 3. a commented-out remote @import in the bundled CSS: remove, so reports contain no remote URL at all.
embed = re.sub(r"/\* @import url\('https://fonts\.googleapis\.com/[^']*'\); \*/", "", embed)
embed = embed.replace("//# sourceMappingURL=embed.js.map", "")
write("jupyter-widgets-embed.js", embed)
versions = {"mathjax": mathjax_pkg, "html-manager": manager_pkg,
            "licenses": {"mathjax": "Apache-2.0", "html-manager": "BSD-3-Clause (see embed.js.LICENSE.txt)"}}
(out / "VERSIONS.json").write_text(json.dumps(versions, indent=2) + "\n")
(out / "jupyter-widgets-embed.LICENSE.txt").write_text((dist / "embed.js.LICENSE.txt").read_text("utf-8"))
PY
