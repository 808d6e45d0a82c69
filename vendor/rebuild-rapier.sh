#!/usr/bin/env bash
# Rebuilds vendor/rapier3d-f64 from the crates.io crate rapier3d-f64 0.36.1 and the patch series
# vendor/patches/NNNN-*.patch (vendor/README.md).
#
#   vendor/rebuild-rapier.sh            rebuild in a temporary directory and compare it byte for
#                                       byte with vendor/rapier3d-f64; exit 1 listing what differs
#   vendor/rebuild-rapier.sh --write    replace vendor/rapier3d-f64 with the rebuilt tree
#   vendor/rebuild-rapier.sh --series DIR
#                                       make DIR a git repository: the pristine crate as its first
#                                       commit, then one commit per patch (`git am`), to edit the
#                                       series (or rebase it onto a new upstream)
#   vendor/rebuild-rapier.sh --export DIR
#                                       write the commits of such a repository after its first one
#                                       back to vendor/patches (`git format-patch`); a patch whose
#                                       subject is unchanged keeps its file name's short part
#
# The crate comes from cargo's cache, `${CARGO_HOME:-~/.cargo}/registry/cache/*/`; when it is not
# there, a throwaway cargo project that depends on `rapier3d-f64 = "=0.36.1"` is fetched (crates.io
# is reached through cargo only, so this needs cargo's network access once; run with
# `CARGO_HOME=$(mktemp -d)` to leave the usual cache alone). The .crate file is checked against
# CRATE_SHA256 below (crates.io's checksum, as a Cargo.lock records it) and unpacked from that very
# file, not from cargo's unpacked copy in registry/src.
#
# The vendored tree is the crate as cargo unpacks it, patched, with these differences
# (reproduced here; see `prune` below):
#   - `tests/` (one integration test, tests/issue_396_halfspace_broad_phase.rs) is left out: the
#     crate is not a workspace member, its tests are not ours. Its Cargo.toml still declares the
#     `[[test]]` target, which only matters to `cargo test` run inside the vendored directory.
#   - `Cargo.lock` is left out: the workspace's own Cargo.lock resolves the crate's dependencies.
#   - `.cargo-ok` ({"v":1}, written by cargo when it unpacks a crate) is kept, as cargo writes it.
# `Cargo.toml` (cargo's normalised manifest) and `Cargo.toml.orig` (the author's) are upstream's,
# unchanged; so are `.cargo_vcs_info.json` and `README.md`. The patches touch `src/` only.
set -euo pipefail

CRATE=rapier3d-f64
VERSION=0.36.1
CRATE_SHA256=f4588855e9c5451702147b5c6ddff4d93887f1e59c9504b6ac3571818f6ec3d2

usage() {
    sed -n '2,16p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
    exit 2
}

mode=compare
series_dir=
while [ $# -gt 0 ]; do
    case "$1" in
        --write) mode=write ;;
        --series)
            [ $# -ge 2 ] || usage
            mode=series
            series_dir=$2
            shift
            ;;
        --export)
            [ $# -ge 2 ] || usage
            mode=export
            series_dir=$2
            shift
            ;;
        -h | --help) usage ;;
        *)
            echo "unknown argument: $1" >&2
            usage
            ;;
    esac
    shift
done

vendor_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
vendored=$vendor_dir/$CRATE
patches=("$vendor_dir"/patches/[0-9][0-9][0-9][0-9]-*.patch)
[ -e "${patches[0]}" ] || {
    echo "no patches in $vendor_dir/patches" >&2
    exit 1
}
cargo_home=${CARGO_HOME:-$HOME/.cargo}

work=$(mktemp -d "${TMPDIR:-/tmp}/rebuild-rapier.XXXXXX")
trap 'rm -rf "$work"' EXIT

# The subject of a patch file (its header, continuation lines joined; as git encodes it), without
# the "[PATCH n/m] " prefix.
subject() {
    awk '/^Subject: /{on=1; printf "%s", substr($0, 10); next}
         on && /^ /{printf "%s", $0; next}
         {on=0}
         /^$/{exit}' "$1" | sed 's/^\[PATCH[^]]*\] //'
}

if [ "$mode" = export ]; then
    base=$(git -C "$series_dir" rev-list --max-parents=0 HEAD)
    git -C "$series_dir" format-patch -q --zero-commit --no-signature -o "$work/export" "$base..HEAD"
    declare -A short_name
    for p in "${patches[@]}"; do
        n=$(basename "$p" .patch)
        short_name[$(subject "$p")]=${n#[0-9][0-9][0-9][0-9]-}
    done
    mkdir "$work/named"
    for f in "$work"/export/*.patch; do
        n=$(basename "$f")
        s=$(subject "$f")
        if [ -n "${short_name[$s]:-}" ]; then
            n=${n%%-*}-${short_name[$s]}.patch
        fi
        cp "$f" "$work/named/$n"
    done
    # Only now that the whole series is written: replace the old one.
    rm -f "${patches[@]}"
    cp "$work"/named/*.patch "$vendor_dir/patches/"
    ls "$vendor_dir/patches"
    exit 0
fi

# The cached .crate file whose sha256 is CRATE_SHA256, if any.
find_crate() {
    local f
    for f in "$cargo_home"/registry/cache/*/"$CRATE-$VERSION.crate"; do
        [ -f "$f" ] || continue
        if [ "$(sha256sum "$f" | cut -d' ' -f1)" = "$CRATE_SHA256" ]; then
            echo "$f"
            return 0
        fi
        echo "warning: $f does not have the recorded sha256; ignored" >&2
    done
    return 1
}

if ! crate_file=$(find_crate); then
    echo "== fetching $CRATE $VERSION with cargo (CARGO_HOME=$cargo_home)"
    mkdir -p "$work/fetch/src"
    cat >"$work/fetch/Cargo.toml" <<EOF
[package]
name = "rebuild-rapier-fetch"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
$CRATE = "=$VERSION"

[workspace]
EOF
    : >"$work/fetch/src/lib.rs"
    CARGO_HOME=$cargo_home cargo fetch --quiet --manifest-path "$work/fetch/Cargo.toml"
    crate_file=$(find_crate) || {
        echo "cargo fetched no $CRATE-$VERSION.crate with sha256 $CRATE_SHA256" >&2
        exit 1
    }
fi
echo "== $crate_file (sha256 $CRATE_SHA256: ok)"

# Unpack as cargo does (the archive holds one directory, $CRATE-$VERSION/), then patch.
tar -xzf "$crate_file" -C "$work"
tree=$work/$CRATE-$VERSION
[ -d "$tree/src" ] || {
    echo "unexpected archive layout: no $CRATE-$VERSION/src" >&2
    exit 1
}
printf '{"v":1}' >"$tree/.cargo-ok"

# What the vendored copy leaves out (see the header).
prune() {
    rm -rf "$1/tests" "$1/Cargo.lock"
}

if [ "$mode" = series ]; then
    [ ! -e "$series_dir" ] || {
        echo "$series_dir already exists" >&2
        exit 1
    }
    cp -a "$tree" "$series_dir"
    cd "$series_dir"
    git init -q
    git add -A
    git -c user.name=crates.io -c user.email=crates.io@invalid \
        commit -q -m "$CRATE $VERSION (crates.io, pristine)"
    # The patches keep their author; the committer is whoever runs this (or a placeholder).
    git -c user.name="$(git config user.name || echo rebuild-rapier)" \
        -c user.email="$(git config user.email || echo rebuild-rapier@invalid)" \
        am -q "${patches[@]}" || {
        echo "git am stopped at the patch above. In $series_dir: apply what applies with" \
            "'git apply --reject .git/rebase-apply/patch', merge the *.rej hunks by hand, delete" \
            "the .rej files, 'git add -A && git am --continue'; then check every commit builds" >&2
        exit 1
    }
    echo "== $series_dir: $CRATE $VERSION + ${#patches[@]} patches as commits:"
    git log --oneline
    echo "(the vendored tree is this one without: tests/ Cargo.lock .git)"
    exit 0
fi

for p in "${patches[@]}"; do
    echo "== applying $(basename "$p")"
    patch -d "$tree" -p1 --forward --fuzz=0 --no-backup-if-mismatch --reject-file=- --quiet <"$p"
done
prune "$tree"

if [ "$mode" = write ]; then
    rm -rf "$vendored"
    cp -a "$tree" "$vendored"
    echo "== $vendored replaced"
    exit 0
fi

# One line per file: "differs: PATH", "only in the rebuilt tree: PATH", "only in vendor: PATH".
differ=$(diff -rq "$tree" "$vendored" |
    sed -e "s|^Files $tree/\(.*\) and $vendored/.* differ\$|differs: \1|" \
        -e "s|^Only in $tree/\{0,1\}\(.*\): \(.*\)\$|only in the rebuilt tree: \1/\2|" \
        -e "s|^Only in $vendored/\{0,1\}\(.*\): \(.*\)\$|only in vendor/$CRATE: \1/\2|" \
        -e "s|: /|: |" || true)
if [ -n "$differ" ]; then
    echo "== vendor/$CRATE differs from $CRATE $VERSION + vendor/patches:" >&2
    echo "$differ" >&2
    exit 1
fi
echo "== vendor/$CRATE is $CRATE $VERSION + ${#patches[@]} patches, byte for byte"
