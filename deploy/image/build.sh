#!/usr/bin/env bash
# Builds the container image of coins (default name coins:latest) from Debian packages: a Debian
# bookworm root file system made by debootstrap (variant minbase), the runtime packages the
# binaries need, the binaries of a build directory, deploy/configs and the pod entrypoint
# (deploy/image/coins-pod.sh). The tree is imported into podman as an OCI image; nothing is
# pulled from a container registry.
#
# Usage, as root on a Debian bookworm machine (the binaries link against bookworm's libraries):
#   deploy/image/build.sh [BUILD_DIR] [--tag NAME] [--save FILE.tar] [--mirror URL]
#     BUILD_DIR  a build directory holding bin/coins and bin/coins-* (default: build/ of the
#                repository; deploy/build.sh makes it)
#     --tag      the image's name (default coins:latest)
#     --save     also write the image to FILE.tar as an OCI archive, for `podman load -i` or
#                `skopeo copy oci-archive:FILE.tar docker://REGISTRY/coins:TAG`
#     --mirror   the Debian mirror (default http://deb.debian.org/debian)
# Installs debootstrap and podman when they are missing. Takes about 5 minutes and 1 GB in /tmp
# while it runs (removed after). To use the image in a cluster, push it
# (`podman push coins:latest REGISTRY/coins:TAG`) and name it in deploy/k8s/kustomization.yaml.
#
# The image: binaries in /opt/coins/bin (on PATH; `coins run` starts its children from there),
# configs in /opt/coins/configs, `coins-pod` (the entrypoint of deploy/k8s/), the user coins
# (uid/gid 10001), /data as the working directory; the default command is `coins --help`.
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
build_dir=$repo/build
tag=coins:latest
save=""
mirror=http://deb.debian.org/debian
while [ $# -gt 0 ]; do
  case "$1" in
    --tag) tag=$2; shift 2 ;;
    --save) save=$2; shift 2 ;;
    --mirror) mirror=$2; shift 2 ;;
    -h | --help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) echo "build.sh: unknown option $1" >&2; exit 2 ;;
    *) build_dir=$1; shift ;;
  esac
done

# the Debian packages of the shared libraries the binaries load (ldd of the binaries on bookworm),
# plus what they run: gnuplot (learning curves), openssl (coins security init); software EGL
# (Mesa) for the MuJoCo renderer
packages=(
  libfastrtps2.9 libfastcdr1 libfoonathan-memory0.7.2 libssl3
  libmujoco2.2.2 libccd2 libqhull-r8.0 libtinyxml2-9 liblodepng0
  libcholmod3 libspqr2 libblas3 liblapack3 libgomp1
  libyaml-cpp0.7 libspdlog1.10 libfmt9
  libegl1 libegl-mesa0 libgl1-mesa-dri libpng16-16 libgif7
  gnuplot-nox openssl procps
)

die() { echo "build.sh: $*" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || die "run as root (debootstrap and podman import need it)"
[ -x "$build_dir/bin/coins" ] || die "$build_dir/bin/coins not found: build first (deploy/build.sh) or name the build directory"
. /etc/os-release
[ "${VERSION_CODENAME:-}" = bookworm ] ||
  echo "build.sh: warning: this machine is ${PRETTY_NAME:-unknown}, the image is bookworm: the binaries may not load" >&2
missing=()
command -v debootstrap >/dev/null || missing+=(debootstrap)
command -v podman >/dev/null || missing+=(podman)
if [ ${#missing[@]} -gt 0 ]; then
  echo "build.sh: installing ${missing[*]}"
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi

rootfs=$(mktemp -d /tmp/coins-rootfs.XXXXXX)
cleanup() { rm -rf --one-file-system "$rootfs"; }
trap cleanup EXIT

echo "build.sh: debootstrap bookworm (minbase) into $rootfs"
debootstrap --variant=minbase bookworm "$rootfs" "$mirror" > "$rootfs.log" 2>&1 ||
  { tail -20 "$rootfs.log" >&2; die "debootstrap failed (log $rootfs.log)"; }
rm -f "$rootfs.log"

in_root() { chroot "$rootfs" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive "$@"; }
# the security archive beside the mirror's (".../debian" -> ".../debian-security")
security=${mirror%/}-security
cat > "$rootfs/etc/apt/sources.list" <<EOF
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb $security bookworm-security main
EOF
cp /etc/resolv.conf "$rootfs/etc/resolv.conf"
printf '#!/bin/sh\nexit 101\n' > "$rootfs/usr/sbin/policy-rc.d" && chmod 755 "$rootfs/usr/sbin/policy-rc.d"
echo "build.sh: installing ${#packages[@]} runtime packages"
in_root apt-get update -qq
in_root apt-get install -y -qq --no-install-recommends "${packages[@]}" > /dev/null

echo "build.sh: copying the binaries of $build_dir/bin, deploy/configs and coins-pod"
install -d "$rootfs/opt/coins/bin" "$rootfs/opt/coins/configs" "$rootfs/data"
for f in "$build_dir"/bin/coins "$build_dir"/bin/coins-*; do
  [ -f "$f" ] && [ -x "$f" ] && install -m 755 "$f" "$rootfs/opt/coins/bin/"
done
cp -r "$repo"/deploy/configs/. "$rootfs/opt/coins/configs/"
install -m 755 "$repo/deploy/image/coins-pod.sh" "$rootfs/usr/local/bin/coins-pod"
in_root groupadd -g 10001 coins
in_root useradd -u 10001 -g 10001 -d /data -M -s /usr/sbin/nologin coins
chown 10001:10001 "$rootfs/data"

# every binary must find its libraries in the image
if unresolved=$(in_root sh -c 'for b in /opt/coins/bin/*; do ldd "$b"; done' | grep "not found" | sort -u) &&
  [ -n "$unresolved" ]; then
  die "libraries missing in the image (add their packages to build.sh):
$unresolved"
fi

in_root apt-get clean
rm -rf "$rootfs"/var/lib/apt/lists/* "$rootfs"/var/cache/apt/*.bin "$rootfs"/usr/share/doc/* \
  "$rootfs"/usr/share/man/* "$rootfs"/usr/share/info/* "$rootfs"/var/log/*.log "$rootfs"/var/log/apt/* \
  "$rootfs/usr/sbin/policy-rc.d" "$rootfs/etc/resolv.conf"
: > "$rootfs/etc/resolv.conf"

revision=$(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "build.sh: importing into podman as $tag"
tar -C "$rootfs" --numeric-owner -cf - . | podman import \
  --change 'ENV PATH=/opt/coins/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
  --change 'ENV LANG=C.UTF-8' \
  --change 'WORKDIR /data' \
  --change 'CMD ["coins", "--help"]' \
  --change "LABEL org.opencontainers.image.title=coins" \
  --change "LABEL org.opencontainers.image.revision=$revision" \
  --message "coins $revision: Debian bookworm minbase and runtime packages" \
  - "$tag" > /dev/null
[ -n "$save" ] && podman save --format oci-archive -o "$save" "$tag" && echo "build.sh: saved $save"
podman images --format '{{.Repository}}:{{.Tag}} {{.ID}} {{.Size}}' "$tag"
if out=$(podman run --rm --network none "$tag" coins --help 2>&1); then
  echo "build.sh: $tag runs coins --help"
else
  echo "build.sh: warning: the image is built, but podman cannot run it on this machine: ${out##*$'\n'}" >&2
fi
