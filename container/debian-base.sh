#!/usr/bin/env bash
# Makes a Debian 12 base image from Debian's own packages (debootstrap), for building the
# Containerfile where no image registry is reachable. Prints the image's name.
#
#   container/debian-base.sh [IMAGE]      (default localhost/bw4t-debian:bookworm)
#
# Needs root (debootstrap), buildah and a Debian mirror; an image already there is kept.
set -euo pipefail

image=${1:-localhost/bw4t-debian:bookworm}
mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}

if buildah inspect --type image "$image" >/dev/null 2>&1; then
    echo "$image"
    exit 0
fi
command -v debootstrap >/dev/null || { echo "debootstrap is needed: apt-get install debootstrap" >&2; exit 1; }

rootfs=$(mktemp -d)
container=
cleanup() {
    [ -n "$container" ] && buildah rm "$container" >/dev/null 2>&1
    rm -rf "$rootfs"
}
trap cleanup EXIT

# minbase: essential packages and apt, as the official slim image has.
debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >&2
rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*

container=$(buildah from scratch)
mountpoint=$(buildah mount "$container")
tar -C "$rootfs" -c . | tar -C "$mountpoint" -x
buildah umount "$container" >/dev/null
buildah config --env PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin --cmd /bin/bash "$container"
buildah commit --quiet "$container" "$image" >/dev/null
echo "$image"
