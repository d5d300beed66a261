#!/usr/bin/env bash
# Formats the C++ sources (*.cc, *.h) with .clang-format, using Debian bookworm's clang-format 14
# (other versions break lines differently). deploy/install-deps.sh installs it.
#   deploy/format.sh            rewrites the files that differ
#   deploy/format.sh --check    changes nothing; lists the files that differ and exits 1 if any
set -euo pipefail
cd "$(dirname "$0")/.."
tool=clang-format-14
if ! command -v "$tool" > /dev/null; then
  echo "format: $tool is missing (bash deploy/install-deps.sh installs it)" >&2
  exit 1
fi
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  mapfile -t files < <(git ls-files --cached --others --exclude-standard '*.cc' '*.h')
else
  mapfile -t files < <(find . -path './build*' -prune -o -type f \( -name '*.cc' -o -name '*.h' \) -print)
fi
if [ "${1:-}" != "--check" ]; then
  "$tool" -i "${files[@]}"
  echo "format: ${#files[@]} files formatted"
  exit 0
fi
# one run over every file; each difference is a "FILE:LINE:COL: warning: ..." line
mapfile -t differ < <("$tool" --dry-run "${files[@]}" 2>&1 | sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: warning: .*/\1/p' | sort -u)
if [ ${#differ[@]} -gt 0 ]; then
  echo "format: ${#differ[@]} of ${#files[@]} files are not formatted (bash deploy/format.sh fixes them):" >&2
  printf '  %s\n' "${differ[@]}" >&2
  exit 1
fi
echo "format: ${#files[@]} files formatted as .clang-format says"
