#!/usr/bin/env bash
# Type-check the packages (strict) and the tests and scenarios. Test directories are not
# packages (pytest puts each on sys.path, and tests/ for its shared helpers), so each is
# checked with itself and tests/ on the path.
set -uo pipefail
cd "$(dirname "$0")/.."
mypy=${MYPY:-mypy}
if [ -z "${MYPY:-}" ] && [ -x .venv/bin/mypy ]; then
    mypy=.venv/bin/mypy
fi
status=0
"$mypy" -p multicosim -p pytest_multicosim || status=1
"$mypy" --no-namespace-packages tests/*.py tests/typing/check_public_types.py || status=1
for dir in tests/*/ scenarios/; do
    dir=${dir%/}
    files=("$dir"/*.py)
    [ -e "${files[0]}" ] || continue
    MYPYPATH="$dir:tests" "$mypy" --no-namespace-packages "${files[@]}" || status=1
done
exit "$status"
