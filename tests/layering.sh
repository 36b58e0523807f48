#!/bin/sh
# layering.sh: every folder of src/ has a README.md, and uses only the folders its README allows
# ("May use: core, io, ..." up to the first full stop; words in parentheses are comments). Read
# from the built objects: each symbol a folder's objects leave undefined is looked up among the
# global symbols the other folders define, so a call across the line fails here whatever header
# it came through.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${BUILD:-$root/build}
TEST=layering
. "$(dirname "$0")/cli_common.shlib"
command -v nm >/dev/null || fail "nm is missing (binutils, which gcc brings)"
folders=$(cd "$root/src" && for d in */; do echo "${d%/}"; done)
: >defined.txt
for f in $folders; do
    [ -f "$root/src/$f/README.md" ] || fail "src/$f has no README.md"
    set -- "$BUILD"/src/"$f"/*.o
    [ -f "$1" ] || fail "no objects in $BUILD/src/$f (build the library first)"
    nm -g --defined-only "$@" | awk -v f="$f" 'NF == 3 { print $3, f }' >>defined.txt
done
[ -s defined.txt ] || fail "no symbols found in $BUILD/src"
bad=0
for f in $folders; do
    # The README's "May use:" sentence as folder names.
    allowed=$(tr '\n' ' ' <"$root/src/$f/README.md" | sed -n 's/.*May use: *//p' | sed -e 's/([^)]*)//g' -e 's/\..*//' |
        tr -c 'a-z\n' ' ')
    grep -q "May use:" "$root/src/$f/README.md" || fail "src/$f/README.md has no \"May use:\" sentence"
    uses=$(nm -u "$BUILD"/src/"$f"/*.o | awk 'NF == 2 { print $2 }' | sort -u |
        awk -v f="$f" 'NR == FNR { home[$1] = $2; next } ($1 in home) && home[$1] != f { print home[$1], $1 }' \
            defined.txt -)
    [ -n "$uses" ] || continue
    for g in $(echo "$uses" | awk '{ print $1 }' | sort -u); do
        case " $allowed " in
        *" $g "*) ;;
        *)
            echo "layering: src/$f uses src/$g, which its README does not allow:" \
                "$(echo "$uses" | awk -v g="$g" '$1 == g { print $2 }' | head -5 | tr '\n' ' ')" >&2
            bad=1
            ;;
        esac
    done
done
[ $bad -eq 0 ] || fail "a folder uses one its README does not allow (fix the call or the README and docs/architecture.md)"
echo "layering: $(echo $folders | wc -w) folders, each uses only what its README allows"
