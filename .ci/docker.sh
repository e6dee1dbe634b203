#!/usr/bin/env bash
# Make a Docker engine available and build multicosim's images; idempotent, fast when done.
#
#   .ci/docker.sh            install + start the engine, build the images
#   .ci/docker.sh --no-build install + start the engine only
#
# PYTHON selects the interpreter that has multicosim installed (default: python3).
# No container registry is reachable from our machines: images are built locally, from a
# base image made with debootstrap when no base image exists (see multicosim/docker/_images.py).
set -euo pipefail

PYTHON="${PYTHON:-python3}"
BUILD=1
[[ "${1:-}" == "--no-build" ]] && BUILD=0

as_root() {
    if [[ $(id -u) -eq 0 ]]; then "$@"; else sudo "$@"; fi
}

# debootstrap makes the base image where no registry is reachable (see _images.py).
missing=()
command -v dockerd >/dev/null 2>&1 || missing+=(docker.io)
[[ $BUILD -eq 1 ]] && ! command -v debootstrap >/dev/null 2>&1 \
    && ! PATH="$PATH:/usr/sbin:/sbin" command -v debootstrap >/dev/null 2>&1 && missing+=(debootstrap)
if [[ ${#missing[@]} -gt 0 ]]; then
    echo "docker.sh: installing ${missing[*]}"
    as_root apt-get update -qq
    DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq "${missing[@]}" >/dev/null
fi

if ! docker info >/dev/null 2>&1; then
    echo "docker.sh: starting dockerd (log: ${TMPDIR:-/tmp}/dockerd.log)"
    # setsid + nohup: the engine must outlive this script and the CI step that ran it.
    as_root setsid nohup dockerd >"${TMPDIR:-/tmp}/dockerd.log" 2>&1 </dev/null &
    for _ in $(seq 1 150); do
        docker info >/dev/null 2>&1 && break
        sleep 0.2
    done
    if ! docker info >/dev/null 2>&1; then
        echo "docker.sh: dockerd did not answer within 30 s; its log:" >&2
        tail -n 40 "${TMPDIR:-/tmp}/dockerd.log" >&2 || true
        exit 1
    fi
fi
echo "docker.sh: engine $(docker version --format '{{.Server.Version}}') is running"

if [[ $BUILD -eq 1 ]]; then
    cd "$(dirname "$0")/.."
    "$PYTHON" -m multicosim images build
fi
