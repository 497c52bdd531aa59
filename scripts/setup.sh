#!/usr/bin/env bash
# Installs the system packages dea-mpi needs on Debian 12 (idempotent) and builds it in
# release mode. As root it calls apt-get directly, otherwise through sudo.
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/packages.sh
ensure_packages setup libopenmpi-dev openmpi-bin libhdf5-dev libclang-dev clang pkg-config
if ! command -v cargo >/dev/null 2>&1; then
    echo "setup: cargo (Rust toolchain) not found; install Rust from https://rustup.rs first" >&2
    exit 1
fi
# cargo's own output: the first build takes minutes and shows what it compiles as it goes
cargo build --release --locked
