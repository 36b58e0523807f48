#!/bin/sh
# exports.sh: libhdnet.so exports the public API and nothing else. Every dynamic symbol it defines
# is a function include/hdnet.h declares (read from the header's text here, not from the version
# script the Makefile makes), every function the header declares is exported, and the library's
# internal functions (global in libhdnet.a, absent from the header, e.g. hd_photo_raster_build)
# are not.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${BUILD:-$root/build}
TEST=exports
. "$(dirname "$0")/cli_common.shlib"
command -v nm >/dev/null || fail "nm is missing (binutils, which gcc brings)"
so=$(readlink -f "$BUILD/libhdnet.so") && [ -f "$so" ] || fail "$BUILD/libhdnet.so is not built"
[ -f "$BUILD/libhdnet.a" ] || fail "$BUILD/libhdnet.a is not built"
header=$root/include/hdnet.h

nm -D --defined-only "$so" | awk 'NF == 3 { print $3 }' | sort -u >exported.txt
[ -s exported.txt ] || fail "$so exports nothing"
# The functions the header declares: a name followed by "(" on a line that is not a comment, a
# macro or a static inline.
sed -e 's|/\*.*\*/||g' "$header" | grep -v '^ *\*\|^ */\*\|^#\|static inline' |
    grep -o '\bhd_[a-z0-9_]*(' | tr -d '(' | sort -u >declared.txt
[ "$(wc -l <declared.txt)" -gt 50 ] || fail "found only $(wc -l <declared.txt) declarations in $header"

extra=$(comm -23 exported.txt declared.txt | head -10)
[ -z "$extra" ] || fail "libhdnet.so exports symbols hdnet.h does not declare: $(echo $extra)"
missing=$(comm -13 exported.txt declared.txt | head -10)
[ -z "$missing" ] || fail "hdnet.h declares functions libhdnet.so does not export: $(echo $missing)"

nm -g --defined-only "$BUILD/libhdnet.a" 2>/dev/null | awk 'NF == 3 && $2 ~ /[TDBR]/ { print $3 }' | sort -u >static.txt
comm -23 static.txt declared.txt >internal.txt
grep -qx hd_photo_raster_build internal.txt || fail "hd_photo_raster_build is not an internal symbol of libhdnet.a"
leaked=$(comm -12 internal.txt exported.txt | head -10)
[ -z "$leaked" ] || fail "libhdnet.so exports internal symbols: $(echo $leaked)"
echo "exports: libhdnet.so exports the $(wc -l <exported.txt) functions of hdnet.h; $(wc -l <internal.txt) internal symbols of libhdnet.a stay hidden"
