#!/usr/bin/env bash
# Install libsightline (the C ABI of sightline-runtime) into a prefix: the header, the shared
# library (with its SONAME link and the -lsightline link), the static library and sightline.pc.
#
#   tools/install-capi.sh PREFIX                  # builds in release first
#   tools/install-capi.sh PREFIX --from DIR       # installs what a build left in DIR (no build)
#
# Then: cc app.c $(pkg-config --cflags --libs sightline)                 (shared)
#       cc -static app.c $(pkg-config --static --cflags --libs sightline) (static)
# with PKG_CONFIG_PATH=PREFIX/lib/pkgconfig when PREFIX is not one pkg-config searches.
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { echo "usage: $0 PREFIX [--from TARGET_DIR]" >&2; exit 2; }
[ $# -ge 1 ] || usage
prefix=$1
shift
from=""
while [ $# -gt 0 ]; do
    case $1 in
        --from) [ $# -ge 2 ] || usage; from=$2; shift 2 ;;
        *) usage ;;
    esac
done
mkdir -p "$prefix"
prefix=$(cd "$prefix" && pwd)

if [ -z "$from" ]; then
    echo "building libsightline (cargo build --release --locked -p sightline-capi) ..." >&2
    cargo build --release --locked -p sightline-capi
    from=target/release
fi
for f in libsightline_capi.so libsightline_capi.a; do
    [ -f "$from/$f" ] || { echo "error: $from/$f is missing (build sightline-capi first)" >&2; exit 2; }
done
version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
[ -n "$version" ] || { echo "error: no version in Cargo.toml" >&2; exit 2; }

install -d "$prefix/include" "$prefix/lib/pkgconfig"
install -m644 runtime/capi/include/sightline.h "$prefix/include/sightline.h"
install -m755 "$from/libsightline_capi.so" "$prefix/lib/libsightline.so.$version"
ln -sf "libsightline.so.$version" "$prefix/lib/libsightline.so.0"   # the SONAME
ln -sf libsightline.so.0 "$prefix/lib/libsightline.so"             # for -lsightline
install -m644 "$from/libsightline_capi.a" "$prefix/lib/libsightline.a"
sed -e "s|@PREFIX@|$prefix|" -e "s|@VERSION@|$version|" runtime/capi/sightline.pc.in \
    > "$prefix/lib/pkgconfig/sightline.pc"
echo "installed libsightline $version into $prefix" >&2

# The dynamic loader finds the library only in its own folders: refresh its cache for the usual
# system prefixes (as root), otherwise say how a program finds it.
case $prefix in
    /usr | /usr/local)
        if [ "$(id -u)" = 0 ] && command -v ldconfig >/dev/null; then ldconfig; fi ;;
esac
if ! ldconfig -p 2>/dev/null | grep -q "$prefix/lib/libsightline.so.0"; then
    cat >&2 <<NOTE
note: $prefix/lib is not in the dynamic loader's folders. Link programs with
      -Wl,-rpath,$prefix/lib (or set LD_LIBRARY_PATH=$prefix/lib, or add the folder to
      /etc/ld.so.conf.d/ and run ldconfig), else they stop with
      "libsightline.so.0: cannot open shared object file". Static linking needs none of this.
NOTE
fi
