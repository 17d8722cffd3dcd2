#!/usr/bin/env bash
# Fails when a C++ source or header of the tree differs from what clang-format (the root
# .clang-format, Debian 12's clang-format 14) makes of it, and names every such file.
# usage: check_format.sh SOURCE_DIR [CLANG_FORMAT]
set -euo pipefail
source_dir=$1
clang_format=${2:-clang-format}
cd "$source_dir"
mapfile -t files < <(find bench client common server sim tests tools -type f \
  \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' -o -name '*.cc' \) -not -path '*/data/*' | sort)
[ ${#files[@]} -gt 0 ] || { echo "check_format: no C++ files under $source_dir" >&2; exit 1; }
unformatted=()
for f in "${files[@]}"; do
  "$clang_format" --dry-run -Werror "$f" >/dev/null 2>&1 || unformatted+=("$f")
done
if [ ${#unformatted[@]} -gt 0 ]; then
  echo "check_format: ${#unformatted[@]} of ${#files[@]} files are not clang-formatted" \
    "(fix with: clang-format -i FILE):" >&2
  printf '  %s\n' "${unformatted[@]}" >&2
  exit 1
fi
echo "check_format: ${#files[@]} files formatted"
