#!/usr/bin/env bash
# Installs the system packages dea-mpi needs on Debian 12 (idempotent) and builds it in
# release mode. As root it calls apt-get directly, otherwise through sudo.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(libopenmpi-dev openmpi-bin libhdf5-dev libclang-dev clang pkg-config)
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
    as_root=()
    [ "$(id -u)" -eq 0 ] || as_root=(sudo)
    echo "setup: installing ${missing[*]}"
    "${as_root[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq "${missing[@]}"
fi
if ! command -v cargo >/dev/null 2>&1; then
    echo "setup: cargo (Rust toolchain) not found; install Rust from https://rustup.rs first" >&2
    exit 1
fi
cargo build --release --locked 2>&1 | tail -n 3
