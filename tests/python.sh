#!/bin/sh
# python.sh: the Python module (python/hdnet over $BUILD/libhdnet.so) with Debian's python3 and
# numpy: runs tests/test_python.py. Skips, saying so, when python3 or numpy is missing.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
BUILD=${BUILD:-$root/build}
TEST=python
. "$(dirname "$0")/cli_common.shlib"
py=/usr/bin/python3
if [ ! -x $py ] || ! $py -c 'import numpy' 2>/dev/null; then
    skip "needs Debian's python3 and python3-numpy (make deps installs them)"
fi
[ -e "$BUILD/libhdnet.so.0" ] || fail "$BUILD/libhdnet.so.0 is not built"
export HDNET_LIBRARY="$BUILD/libhdnet.so.0" PYTHONPATH="$root/python" HDNET_DATA="$root/models"
# A library built with AddressSanitizer (make check) needs its runtime loaded first in python3.
case " ${LDFLAGS:-} " in
*-fsanitize=address*)
    LD_PRELOAD=$(${CC:-cc} -print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0 \
        $py "$root/tests/test_python.py" "$root" "$HDNET" || fail "test_python.py failed" ;;
*) $py "$root/tests/test_python.py" "$root" "$HDNET" || fail "test_python.py failed" ;;
esac
