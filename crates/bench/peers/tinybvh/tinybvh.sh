#!/usr/bin/env bash
# Builds the tinybvh peer (tinybvh_peer.cpp beside this script) and prints the path of the
# binary, for the accel-bench suites that time tinybvh in the same rounds as ours (`build`,
# `rays`, `meshes`):
#
#   TINYBVH_PEER=$(crates/bench/peers/tinybvh/tinybvh.sh) cargo run -p accel-bench -- rays
#
# tinybvh is a single C++ header. It is not copied into this repository: cargo fetches the
# `tinybvh-rs` crate, which ships tiny_bvh.h, into its registry, and g++ compiles against it
# there. Needs g++ (Debian's `g++` package).
set -euo pipefail
version="0.1.0-beta.3" # tinybvh-rs; ships tinybvh 1.6.8
here="$(cd "$(dirname "$0")" && pwd)"
out="${TINYBVH_PEER_DIR:-${CARGO_TARGET_DIR:-$(cd "$here/../../../.." && pwd)/target}/tinybvh_peer}"
mkdir -p "$out/fetch/src"
cat >"$out/fetch/Cargo.toml" <<TOML
[package]
name = "tinybvh-fetch"
version = "0.0.0"
edition = "2021"
publish = false
[workspace]
[dependencies]
tinybvh-rs = "=$version"
TOML
touch "$out/fetch/src/lib.rs"
cargo fetch --quiet --manifest-path "$out/fetch/Cargo.toml" >&2
registry="${CARGO_HOME:-$HOME/.cargo}/registry/src"
header="$(ls -d "$registry"/*/"tinybvh-rs-$version"/ffi/tinybvh 2>/dev/null | head -n 1)"
if [ ! -f "$header/tiny_bvh.h" ]; then
  echo "tinybvh.sh: tiny_bvh.h not found under $registry after cargo fetch" >&2
  exit 1
fi
# tinybvh's ray traversals keep their stacks in fixed 256-entry arrays, which the benchmark's
# incoherent rays (origins inside the 1M-triangle scene) overflow in the BVH4_CPU and BVH8_CPU
# layouts over its binned build (AddressSanitizer: stack-buffer-overflow in
# BVH4_CPU::Intersect). The peer is compiled against a copy whose traversal stacks hold 8,192
# entries; nothing else in the header changes.
mkdir -p "$out/include"
sed -e 's/\(nodeStack\|distStack\)\[256\]/\1[8192]/' "$header/tiny_bvh.h" >"$out/include/tiny_bvh.h.new"
if [ "$(grep -c 'Stack\[8192\]' "$out/include/tiny_bvh.h.new")" -ne 6 ]; then
  echo "tinybvh.sh: expected six 256-entry traversal stacks in tiny_bvh.h $version" >&2
  exit 1
fi
if ! cmp -s "$out/include/tiny_bvh.h.new" "$out/include/tiny_bvh.h"; then
  mv "$out/include/tiny_bvh.h.new" "$out/include/tiny_bvh.h"
else
  rm "$out/include/tiny_bvh.h.new"
fi
binary="$out/tinybvh_peer"
if [ ! -x "$binary" ] || [ "$here/tinybvh_peer.cpp" -nt "$binary" ] || [ "$out/include/tiny_bvh.h" -nt "$binary" ]; then
  g++ -std=c++20 -O3 -march=native -w -I "$out/include" "$here/tinybvh_peer.cpp" -o "$binary" >&2
fi
echo "$binary"
