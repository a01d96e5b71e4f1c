#!/usr/bin/env bash
# System packages skyrender needs: a libLLVM >= 17 for Dr.Jit's LLVM backend.
# (LLVM 15/16 load but abort the process on the first kernel, so they never count.)
set -euo pipefail
have_llvm() {
  for f in /usr/lib/x86_64-linux-gnu/libLLVM*.so* /usr/lib/aarch64-linux-gnu/libLLVM*.so* /usr/lib/llvm-*/lib/libLLVM*.so*; do
    [[ -e $f ]] || continue
    v=$(basename "$f" | sed -nE 's/^libLLVM[-.](so\.)?([0-9]+).*/\2/p')
    [[ -z $v ]] && v=$(echo "$f" | sed -nE 's#.*/llvm-([0-9]+)/.*#\1#p')
    [[ -n $v && $v -ge 17 ]] && return 0
  done
  return 1
}
if have_llvm; then
  exit 0
fi
if [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null; then
  echo "skyrender: installing libllvm19 (Dr.Jit's LLVM backend)" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq libllvm19 >/dev/null
elif command -v apt-get >/dev/null; then
  echo "skyrender: Dr.Jit needs LLVM >= 17; run: sudo apt-get install -y libllvm19" >&2
  echo "skyrender: continuing; the slow scalar_rgb Mitsuba variant will be used meanwhile" >&2
else
  echo "skyrender: Dr.Jit needs LLVM >= 17 (libLLVM 19 recommended); install it with your package manager" >&2
fi
