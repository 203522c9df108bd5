#!/usr/bin/env bash
# Checks that every C++ source and header in git is as clang-format (Debian 12's clang-format 14,
# .clang-format) writes it; names each file that is not and exits 1. Installs clang-format if
# missing. To fix: git ls-files '*.cpp' '*.h' | xargs clang-format -i
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v clang-format >/dev/null 2>&1; then
  sudo=""
  [ "$(id -u)" = 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends clang-format >/dev/null
fi
bad=$(git ls-files '*.cpp' '*.h' | xargs clang-format --dry-run 2>&1 |
      sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: \(warning\|error\): code should be clang-formatted.*/\1/p' | sort -u)
if [ -n "$bad" ]; then
  echo "raywarp format: these files are not as clang-format writes them:"
  echo "$bad" | sed 's/^/  /'
  echo "fix: git ls-files '*.cpp' '*.h' | xargs clang-format -i"
  exit 1
fi
echo "raywarp format: $(git ls-files '*.cpp' '*.h' | wc -l) files as clang-format writes them"
