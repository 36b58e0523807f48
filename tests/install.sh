#!/bin/sh
# install.sh: `make install` into a temporary prefix, then an outside C program built with
# pkg-config against it (the shared library, then the static one) relights the bundled photo from
# an unrelated folder, with no HDNET_DATA: the default model and the face models are found through
# the prefix compiled into the library. Its pixels must equal those of the installed
# `hdnet relight`. Checks the soname, the version and that the static build carries no libhdnet.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
TEST=install
. "$(dirname "$0")/cli_common.shlib"
unset HDNET_DATA
command -v pkg-config >/dev/null || fail "pkg-config is missing (make deps installs it)"
prefix=$(pwd)/prefix
# BUILD is the folder `make test` runs from; the parent's make flags (HD_DNNL, sanitizers) carry over.
make -s -C "$root" --no-print-directory ${BUILD:+BUILD="$BUILD"} PREFIX="$prefix" install >make.log 2>&1 ||
    { cat make.log >&2; fail "make install PREFIX=$prefix failed"; }
for f in bin/hdnet include/hdnet.h lib/libhdnet.a lib/pkgconfig/hdnet.pc share/hdnet/hdnet-synth.safetensors; do
    [ -e "$prefix/$f" ] || fail "make install did not install $f"
done
real=$(cd "$prefix/lib" && ls libhdnet.so.*.*.*) || fail "no versioned libhdnet.so.MAJOR.MINOR.PATCH"
major=${real#libhdnet.so.}; major=${major%%.*}
[ "$(readlink "$prefix/lib/libhdnet.so")" = "$real" ] || fail "libhdnet.so does not point at $real"
[ "$(readlink "$prefix/lib/libhdnet.so.$major")" = "$real" ] || fail "libhdnet.so.$major does not point at $real"
readelf -d "$prefix/lib/$real" | grep -q "SONAME.*\[libhdnet.so.$major\]" || fail "$real has no soname libhdnet.so.$major"

# hdnet.pc's libraries are what libhdnet links: every library the shared one needs (NEEDED) is a
# -l of Libs.private, and every -l there comes from a package of debian-packages.txt's "deps" set
# or one such a package depends on (libjpeg-dev: libjpeg62-turbo-dev), or from gcc's own
# libc6-dev and libgcc-N-dev.
pc=$prefix/lib/pkgconfig/hdnet.pc
libs=$(sed -n 's/^Libs.private: *//p' "$pc")
[ -n "$libs" ] || fail "$pc has no Libs.private"
if command -v dpkg-query >/dev/null; then
    listed=$(awk '!/^#/ && $2 == "deps" { print $1 }' "$root/debian-packages.txt")
    # shellcheck disable=SC2086
    allowed=" $(echo $listed) $(dpkg-query -W -f='${Depends}, ' $listed 2>/dev/null | tr ',|' '\n\n' |
        sed -e 's/(.*)//' -e 's/:any//' -e 's/ //g' | sort -u | tr '\n' ' ') "
fi
sonames=
for flag in $libs; do
    case $flag in -l*) ;; *) continue ;; esac
    file=$(${CC:-cc} -print-file-name="lib${flag#-l}.so")
    [ -e "$file" ] || file=$(${CC:-cc} -print-file-name="lib${flag#-l}.a") # glibc's -lpthread: an empty archive
    [ -e "$file" ] || fail "$pc names $flag, which the compiler cannot find"
    # the soname of a shared library, or of every library a linker script (glibc's libm.so) names
    if readelf -h "$(readlink -f "$file")" >/dev/null 2>&1; then
        sonames="$sonames $(readelf -d "$(readlink -f "$file")" 2>/dev/null | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')"
    else
        sonames="$sonames $(grep -o '[^ (/]*\.so\.[0-9.]*' "$file" | tr '\n' ' ')"
    fi
    if command -v dpkg-query >/dev/null; then
        # the package owning the file, or the one an alternatives link leads to (OpenBLAS)
        owned=$file pkg= step=0
        while [ -z "$pkg" ] && [ $step -lt 5 ]; do
            owned=$(readlink -f "$(dirname "$owned")")/$(basename "$owned")
            pkg=$(dpkg -S "$owned" 2>/dev/null | head -1 | cut -d: -f1)
            [ -n "$pkg" ] || [ ! -L "$owned" ] && break
            link=$(readlink "$owned")
            case $link in /*) owned=$link ;; *) owned=$(dirname "$owned")/$link ;; esac
            step=$((step + 1))
        done
        [ -n "$pkg" ] || fail "$pc names $flag: no Debian package owns $file or what it links to"
        case $pkg in libc6-dev | libgcc-*-dev) ;; *)
            case $allowed in *" $pkg "*) ;; *)
                fail "$pc names $flag from $pkg, which neither debian-packages.txt's deps set nor their dependencies hold" ;;
            esac ;;
        esac
    fi
done
for needed in $(readelf -d "$prefix/lib/$real" | sed -n 's/.*NEEDED.*\[\(.*\)\]/\1/p'); do
    case $needed in libc.so.* | ld-linux* | libgcc_s.so.* | lib*san.so.*) continue ;; esac  # libc, gcc, sanitizers
    case " $sonames " in *" $needed "*) ;; *) fail "$real needs $needed, which hdnet.pc's Libs.private ($libs) does not name" ;; esac
done
command -v dpkg-query >/dev/null && echo "install: hdnet.pc's libraries ($libs) cover what $real needs and come from debian-packages.txt" ||
    echo "install: hdnet.pc's libraries cover what $real needs (SKIP their packages: no dpkg here)"

mkdir -p app elsewhere
cat >app/relight.c <<'APP'
#include <stdio.h>
#include <string.h>
#include <hdnet.h>

int main(int argc, char **argv)
{
    if (argc != 3) return 2;
    if (strcmp(hd_version(), HDNET_VERSION_STRING_FOR_TEST) != 0) {
        fprintf(stderr, "app: library %s, header %s\n", hd_version(), HDNET_VERSION_STRING_FOR_TEST);
        return 1;
    }
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_image photo = {0}, relit = {0};
    float light[HD_SH_COEFFS];
    hd_light_preset(2, light);
    int ok = hd_image_read_as(argv[1], 3, &photo) == HD_OK && hd_model_load(NULL, &model) == HD_OK &&
             hd_aligner_load(&aligner) == HD_OK &&
             hd_relight_photo(model, aligner, &photo, (const float (*)[HD_SH_COEFFS])light, 1, HD_BRIGHTNESS_KEEP,
                              &relit, NULL, NULL) == HD_OK &&
             hd_image_write_pfm(argv[2], &relit) == HD_OK;
    if (!ok) fprintf(stderr, "app: %s\n", hd_error());
    hd_image_free(&photo);
    hd_image_free(&relit);
    hd_aligner_free(aligner);
    hd_model_free(model);
    return ok ? 0 : 1;
}
APP
version=$(sed -n 's/^#define HDNET_VERSION_[A-Z]* \([0-9]*\).*/\1/p' "$prefix/include/hdnet.h" | paste -sd.)
[ "$real" = "libhdnet.so.$version" ] || fail "the library is $real, the header says version $version"
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig"
CC=${CC:-cc}
# shellcheck disable=SC2046,SC2086
$CC ${LDFLAGS:-} -DHDNET_VERSION_STRING_FOR_TEST="\"$version\"" -o app/relight_shared app/relight.c \
    $(pkg-config --cflags --libs hdnet) 2>cc.log || { cat cc.log >&2; fail "the shared build with pkg-config failed"; }
readelf -d app/relight_shared | grep -q "NEEDED.*libhdnet.so.$major" || fail "relight_shared does not link libhdnet.so.$major"
# --static: the same flags plus Libs.private; -l:libhdnet.a picks the archive over the .so
# shellcheck disable=SC2046,SC2086
$CC ${LDFLAGS:-} -DHDNET_VERSION_STRING_FOR_TEST="\"$version\"" -o app/relight_static app/relight.c \
    $(pkg-config --cflags --static --libs hdnet | sed 's/-lhdnet\b/-l:libhdnet.a/') 2>cc.log ||
    { cat cc.log >&2; fail "the static build with pkg-config --static failed"; }
if readelf -d app/relight_static | grep -q "NEEDED.*libhdnet"; then fail "relight_static links libhdnet dynamically"; fi

cd elsewhere
"$prefix/bin/hdnet" relight "$root/examples/astronaut.png" --preset 2 -o cli.pfm >out.log 2>err.log ||
    { cat err.log >&2; fail "the installed hdnet relight failed"; }
for kind in shared static; do
    ../app/relight_$kind "$root/examples/astronaut.png" $kind.pfm 2>err.log || { cat err.log >&2; fail "relight_$kind failed"; }
    cmp -s cli.pfm $kind.pfm || fail "relight_$kind's pixels differ from hdnet relight's"
    echo "install: the $kind build relit the photo from $(pwd) exactly as hdnet relight ($(wc -c <$kind.pfm) bytes)"
done
# The Python module from the prefix, in a few lines, with Debian's python3 (when it has numpy).
if /usr/bin/python3 -c 'import numpy' 2>/dev/null; then
    pydir=$(ls -d "$prefix"/lib/python3*/dist-packages) || fail "make install did not install the Python module"
    case " ${LDFLAGS:-} " in
    *-fsanitize=address*) preload=$(${CC:-cc} -print-file-name=libasan.so) ;;
    *) preload= ;;
    esac
    LD_PRELOAD=$preload ASAN_OPTIONS=detect_leaks=0 PYTHONPATH="$pydir" /usr/bin/python3 - "$root/examples/astronaut.png" <<'PY' ||
import os, sys, hdnet
assert hdnet.__file__.startswith(os.environ["PYTHONPATH"]), hdnet.__file__
photo = hdnet.imread(sys.argv[1])
relit = hdnet.Model().relight(photo, preset=2)
assert (relit == hdnet.imread("cli.pfm")).all(), "python's pixels differ from hdnet relight's"
PY
        fail "the installed Python module did not relight the photo as hdnet relight"
    echo "install: the installed Python module relit the photo exactly as hdnet relight"
else
    [ -z "${CI:-}" ] || [ "${CI:-}" = false ] || fail "the Python module cannot be checked in CI: Debian's python3 and python3-numpy are missing"
    echo "install: SKIP the Python module: needs Debian's python3 and python3-numpy"
fi
echo "install: all checks passed"
