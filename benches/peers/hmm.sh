#!/usr/bin/env bash
# Side by side: pbd's HMM forward passes against hmmlearn's compiled ones, on one machine,
# interleaved (peer, pbd, peer, pbd, ...) and pinned to one core when `taskset` exists.
#
#   benches/peers/hmm.sh [ROUNDS]        (default 3 rounds; run from anywhere)
#
# pbd: `cargo bench -p bayes --bench hmm` cases forward_scaled (hmmlearn's scaling semantics: linear
# lattice in, states below 1e-280 flushed), forward_linear (the same lattice, exact: such states are
# carried in log space) and forward_exact (the log-space recursion), N = 16, T = 100 000, dense and
# left-to-right; plus the library-wide schema inference on a 10-minute demonstration
# (`cargo bench -p schema --bench infer`). Peer: benches/peers/hmm_peer.py (hmmlearn's
# `_hmmc.forward_scaling` and `forward_log` on the same model shapes), in a venv under
# target/peers-venv (created on first use: python3 -m venv + pip install hmmlearn).
# Prints the median obs-steps/s of each round and the ratio pbd / hmmlearn.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"
rounds="${1:-3}"
venv="$root/target/peers-venv"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import hmmlearn" 2>/dev/null; then
    "$venv/bin/pip" install -q "hmmlearn>=0.3,<0.4"
fi
pin=()
if command -v taskset >/dev/null; then pin=(taskset -c 0); else echo "taskset not found: not pinned" >&2; fi

echo "== building the pbd benches"
hmm_bin=$(cargo bench -p bayes --bench hmm --no-run --message-format=json 2>/dev/null \
    | python3 -c 'import json,sys
for l in sys.stdin:
    m=json.loads(l)
    if m.get("reason")=="compiler-artifact" and m["target"]["name"]=="hmm" and m.get("executable"): print(m["executable"])')
infer_bin=$(cargo bench -p schema --bench infer --no-run --message-format=json 2>/dev/null \
    | python3 -c 'import json,sys
for l in sys.stdin:
    m=json.loads(l)
    if m.get("reason")=="compiler-artifact" and m["target"]["name"]=="infer" and m.get("executable"): print(m["executable"])')

# Median time (ns) of one criterion case, from its estimates file.
median_ns() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['median']['point_estimate'])" \
    "target/criterion/$1/new/estimates.json"; }

results="$(mktemp)"
trap 'rm -f "$results"' EXIT
for r in $(seq 1 "$rounds"); do
    echo "== round $r/$rounds: hmmlearn"
    "${pin[@]}" "$venv/bin/python" benches/peers/hmm_peer.py --reps 5 | tee -a "$results"
    echo "== round $r/$rounds: pbd"
    "${pin[@]}" "$hmm_bin" --bench --warm-up-time 1 --measurement-time 3 \
        'hmm_n16_t100k/forward_(scaled|linear|exact)/' >/dev/null
    for kind in dense left_to_right; do
        for case in forward_scaled forward_linear forward_exact; do
            ns=$(median_ns "hmm_n16_t100k/$case/$kind")
            echo "{\"peer\": \"pbd $case\", \"kind\": \"$kind\", \"obs_steps_per_s\": $(python3 -c "print(1e5/($ns*1e-9))")}" \
                | tee -a "$results"
        done
    done
    "${pin[@]}" "$infer_bin" --bench --warm-up-time 1 --measurement-time 3 posterior_library_and_none >/dev/null
    ns=$(median_ns "infer_10min_demo/posterior_library_and_none")
    echo "{\"peer\": \"pbd schema inference\", \"kind\": \"10-minute demo, 7 schemas + none\", \"ms\": $(python3 -c "print($ns*1e-6)")}" \
        | tee -a "$results"
done

echo "== medians over $rounds rounds (obs-steps/s)"
python3 - "$results" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
def med(peer, kind):
    v = [r["obs_steps_per_s"] for r in rows if r["peer"].endswith(peer) and r["kind"] == kind]
    return statistics.median(v) if v else float("nan")
for kind in ("dense", "left_to_right"):
    hs, hl = med("scaling", kind), med("log", kind)
    print(f"{kind:14s} hmmlearn scaling {hs/1e6:6.2f} M   log {hl/1e6:6.2f} M")
    for case, ref, name in (("forward_scaled", hs, "scaling"), ("forward_linear", hs, "scaling"),
                            ("forward_exact", hl, "log")):
        p = med(case, kind)
        print(f"{'':14s} pbd {case:15s} {p/1e6:6.2f} M   = {p/ref:5.2f}x hmmlearn {name}")
inf = [r["ms"] for r in rows if r["peer"] == "pbd schema inference"]
if inf:
    print(f"schema inference, 10-minute demo (7 schemas + none): {statistics.median(inf):.2f} ms")
PY
