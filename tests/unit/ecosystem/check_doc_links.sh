#!/usr/bin/env bash
# Every relative link and picture in README.md and docs/*.md names a file of the
# repository. Usage: check_doc_links.sh REPOSITORY_ROOT
set -euo pipefail
root=${1:?usage: check_doc_links.sh REPOSITORY_ROOT}
missing=0
checked=0
for doc in "$root"/README.md "$root"/docs/*.md; do
  dir=$(dirname "$doc")
  # ](target) and ](target "title"); web addresses and in-page anchors are not files.
  while IFS= read -r target; do
    target=${target%% *}
    target=${target%%#*}
    case $target in ''|http://*|https://*|mailto:*) continue ;; esac
    checked=$((checked + 1))
    if [ ! -e "$dir/$target" ]; then
      echo "${doc#"$root"/}: links to $target, which does not exist" >&2
      missing=$((missing + 1))
    fi
  done < <(grep -oE '\]\([^)]+\)' "$doc" | sed -E 's/^\]\((.*)\)$/\1/')
done
echo "$checked relative links checked, $missing missing"
[ "$missing" -eq 0 ]
