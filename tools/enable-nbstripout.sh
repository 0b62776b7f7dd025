#!/bin/sh
# Enable the nbstripout git filter named in .gitattributes for this clone (git keeps filter
# commands in .git/config, never in the repository). Staging a notebook then strips its
# outputs, execution counts and volatile metadata, and keeps its cell ids (--keep-id), so a
# notebook saved in JupyterLab after a run is committed exactly as it was before the run.
#   tools/enable-nbstripout.sh            (uses python3, or $PYTHON)
set -eu
PYTHON="${PYTHON:-python3}"
"$PYTHON" -m nbstripout --version >/dev/null 2>&1 || {
  echo "nbstripout is not installed: $PYTHON -m pip install -e '.[test]'" >&2; exit 1; }
# JupyterLab rewrites these on every save (they name the machine's Python, not the lab)
VOLATILE="metadata.language_info.version metadata.language_info.codemirror_mode metadata.language_info.file_extension metadata.language_info.mimetype metadata.language_info.nbconvert_exporter metadata.language_info.pygments_lexer metadata.papermill cell.metadata.papermill"
STRIP="$PYTHON -m nbstripout --keep-id --extra-keys '$VOLATILE'"
git config filter.nbstripout.clean "$STRIP"
git config filter.nbstripout.smudge cat
git config filter.nbstripout.required true
git config diff.ipynb.textconv "$STRIP -t"
echo "nbstripout filter enabled: clean = $STRIP"
