#!/usr/bin/env bash
# Steps the scene of main.rs against every state of the rapier patch series (pristine 0.36.1, then
# + patches 1..k) and says, for each patch, whether the final state of every body is byte for byte
# the one of the previous state. Patches whose effect is "none" must print "identical"; those with
# "round-off only" may differ in the last digits. Also runs the last state with
# `multibody_skip_unchanged_kinematics` on (patch 12: must equal the run without it).
#
#   vendor/series-check/run.sh        (builds rapier once per state; ~2 min each with -j1)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/series-check.XXXXXX")
trap 'rm -rf "$work"' EXIT

"$here/../rebuild-rapier.sh" --series "$work/series" >/dev/null
mkdir -p "$work/harness/src" "$work/state"
cp "$here/main.rs" "$work/harness/src/main.rs"
cat >"$work/harness/Cargo.toml" <<TOML
[package]
name = "series-check"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
rapier3d-f64 = { path = "$work/state" }

[profile.dev]
opt-level = 1

[workspace]
TOML
cp "$work/series/Cargo.toml" "$work/state/"

run_state() { # $1: output file, $2: flags.rs contents
    echo "$2" >"$work/harness/flags.rs"
    CARGO_TARGET_DIR=${SERIES_CHECK_TARGET:-$work/target} cargo build -q -j1 \
        --manifest-path "$work/harness/Cargo.toml"
    "${SERIES_CHECK_TARGET:-$work/target}/debug/series-check" >"$1"
}

commits=($(git -C "$work/series" rev-list --reverse HEAD))
status=0
for k in "${!commits[@]}"; do
    git -C "$work/series" checkout -q "${commits[$k]}"
    rm -rf "$work/state/src"
    cp -a "$work/series/src" "$work/state/src"
    run_state "$work/out-$k" "{}"
    subject=$(git -C "$work/series" log -1 --format=%s)
    if [ "$k" -eq 0 ]; then
        echo "pristine: $(tail -1 "$work/out-$k")"
    elif cmp -s "$work/out-$((k - 1))" "$work/out-$k"; then
        printf 'patch %2d: identical (%s)\n' "$k" "$subject"
    else
        printf 'patch %2d: differs   (%s): %s\n' "$k" "$subject" "$(tail -1 "$work/out-$k")"
    fi
done
last=$((${#commits[@]} - 1))
run_state "$work/out-skip" "{ ip.multibody_skip_unchanged_kinematics = true; }"
if cmp -s "$work/out-$last" "$work/out-skip"; then
    echo "last state with multibody_skip_unchanged_kinematics: identical"
else
    echo "last state with multibody_skip_unchanged_kinematics: DIFFERS" >&2
    status=1
fi
exit $status
