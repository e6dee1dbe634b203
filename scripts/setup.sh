#!/usr/bin/env bash
# Create .venv with multicosim and its development tools (idempotent).
# Needs Python 3.11 or 3.12 with venv; on Debian, installs python3-venv when run as root.
set -euo pipefail
cd "$(dirname "$0")/.."

python=${PYTHON:-python3}
if ! "$python" -c 'import sys; sys.exit(not ((3, 11) <= sys.version_info[:2] < (3, 13)))'; then
    echo "multicosim needs Python 3.11 or 3.12; set PYTHON=/path/to/python3.11" >&2
    exit 1
fi
if [ ! -x .venv/bin/python ]; then
    if ! "$python" -m venv .venv 2>/dev/null; then
        rm -rf .venv
        if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
            apt-get update -qq && apt-get install -y -qq python3-venv >/dev/null
            "$python" -m venv .venv
        else
            echo "python3 -m venv failed: install python3-venv (sudo apt-get install python3-venv)" >&2
            exit 1
        fi
    fi
fi
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e '.[dev]'

# The documentation's browser test drives Debian's Chromium through its own driver (nothing
# is downloaded at test time).
if ! command -v chromedriver >/dev/null && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get update -qq && apt-get install -y -qq chromium chromium-driver >/dev/null
fi

# The documentation site serves Mermaid itself (no CDN: the diagrams draw offline), from the
# npm package, pinned and checked against its published integrity; not committed.
mermaid_version=11.12.0
mermaid_integrity=sha512-ZudVx73BwrMJfCFmSSJT84y6u5brEoV8DOItdHomNLz32uBjNrelm7mg95X7g+C6UoQH/W6mBLGDEDv73JdxBg==
mermaid_js=docs/assets/vendor/mermaid.min.js  # mkdocs.yml's extra_javascript
if [ "$(cat "$mermaid_js.version" 2>/dev/null)" != "$mermaid_version" ]; then
    if ! command -v npm >/dev/null && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        apt-get update -qq && apt-get install -y -qq npm >/dev/null
    fi
    if command -v npm >/dev/null; then
        tmp=$(mktemp -d)
        (cd "$tmp" && npm pack --silent "mermaid@$mermaid_version" >/dev/null)
        .venv/bin/python - "$tmp/mermaid-$mermaid_version.tgz" "$mermaid_integrity" "$mermaid_js" <<'PY'
import base64, hashlib, pathlib, sys, tarfile
tgz, integrity, out = sys.argv[1:]
digest = base64.b64encode(hashlib.sha512(pathlib.Path(tgz).read_bytes()).digest()).decode()
if f"sha512-{digest}" != integrity:
    sys.exit(f"{tgz}: integrity sha512-{digest}, expected {integrity}")
with tarfile.open(tgz) as tar:
    js = tar.extractfile("package/dist/mermaid.min.js")
    assert js is not None
    pathlib.Path(out).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(out).write_bytes(js.read())
PY
        rm -rf "$tmp"
        echo "$mermaid_version" >"$mermaid_js.version"
    else
        echo "no npm: the documentation site's diagrams will not draw (install npm)" >&2
    fi
fi
echo "multicosim is installed in .venv"
