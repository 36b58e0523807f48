#!/bin/sh
# batch.sh (make test-mpi): the batch commands split their inputs across MPI ranks (issue 18,
# "inference at scale"). On 3 ranks over a folder of 8 aligned textures (nested, so the layout is
# kept): every output file exists once and is byte-equal to the single-process run's, the --json
# results list every input exactly once, in the single process's order; decompose (its own loop)
# likewise; a broken file on one rank makes the job exit 1 with the job's summary printed once
# (rank 0) counting it; more ranks than inputs works; the progress line comes from rank 0 only.
# A tiny fresh model and --aligned keep it to seconds. Needs mpirun and Debian's python3.
set -eu
: "${HDNET:?HDNET must point at the hdnet binary}"
py=/usr/bin/python3
for need in mpirun "$py"; do
    command -v "$need" >/dev/null 2>&1 || { echo "batch.sh: $need is missing (apt-get install openmpi-bin python3)"; exit 1; }
done
fail() { echo "batch.sh: FAILED: $*"; exit 1; }
mpi() { n=$1; shift; timeout 300 mpirun --allow-run-as-root --oversubscribe -np "$n" "$@"; }
export OMP_NUM_THREADS=1

"$HDNET" init --width 4 --size 32 --seed 1 -o m.safetensors >/dev/null
# 8 different 32 x 32 images (lit spheres), 5 at the top and 3 in a subfolder
mkdir -p tex/sub
for k in 0 1 2 3 4 5 6; do
    d=tex; [ $k -lt 4 ] || d=tex/sub
    "$HDNET" light --preset $k -o l$k.txt --preview $d/s$k.png --size 32 >/dev/null
done
"$HDNET" light --dir 30,10 -o l7.txt --preview tex/sub/t7.png --size 32 >/dev/null
E="estimate-light tex --aligned -m m.safetensors"

# outputs: the same set of files as one process, each byte-equal
"$HDNET" $E -o one -q
mpi 3 "$HDNET" $E -o three > three.log 2> three.err
(cd one && find . -type f | sort) > one.list
(cd three && find . -type f | sort) > three.list
[ "$(wc -l < one.list)" -eq 8 ] || fail "one process wrote $(wc -l < one.list) light files, not 8"
cmp -s one.list three.list || { diff one.list three.list; fail "3 ranks wrote other files than one process"; }
while read -r f; do cmp -s "one/$f" "three/$f" || fail "three/$f differs from one/$f"; done < one.list
# the job's summary, once, from rank 0; the progress line from rank 0 only
[ "$(grep -c '^estimate-light: 8 photos -> three: 8 done (8 faces), 0 without a face, 0 failed' three.log)" -eq 1 ] \
    || { cat three.log three.err; fail "no single job summary of 8 photos"; }
grep -q 'estimate-light (rank 0 of 3) 3/3' three.err || { cat three.err; fail "no progress line of rank 0's 3 inputs"; }
! grep -q 'rank [12] of 3' three.err || { cat three.err; fail "a progress line from another rank than 0"; }
echo "estimate-light on 3 ranks: the 8 outputs of one process, byte-equal; one summary"

# --json: every input once, in the listing's order, and the job's counts
"$HDNET" $E -o one --json > one.json
mpi 3 "$HDNET" $E -o three --json > three.json
"$py" - one.json three.json <<'EOF'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
fa = [r["file"] for r in a["results"]]
fb = [r["file"] for r in b["results"]]
assert len(fb) == 8 and len(set(fb)) == 8, f"3 ranks: {len(fb)} results, {len(set(fb))} distinct"
assert fa == fb, f"order differs:\n{fa}\n{fb}"
assert [r["light"] for r in a["results"]] == [r["light"] for r in b["results"]], "lights differ"
for k in ("inputs", "done", "no_face", "failed", "faces"):
    assert a["summary"][k] == b["summary"][k], (k, a["summary"][k], b["summary"][k])
EOF
echo "estimate-light --json on 3 ranks: 8 results, each input once, as one process"

# decompose runs its own loop: the same split, the same files
D="decompose tex --aligned -m m.safetensors --batch 2"
"$HDNET" $D -o done1 -q
mpi 3 "$HDNET" $D -o done3 > d3.log 2>&1
(cd done1 && find . -type f | sort) > d1.list
(cd done3 && find . -type f | sort) > d3.list
[ "$(wc -l < d1.list)" -ge 40 ] || fail "decompose wrote only $(wc -l < d1.list) files"
cmp -s d1.list d3.list || { diff d1.list d3.list; fail "decompose on 3 ranks wrote other files"; }
while read -r f; do cmp -s "done1/$f" "done3/$f" || fail "done3/$f differs from done1/$f"; done < d1.list
[ "$(grep -c '^decomposed 8 images into done3' d3.log)" -eq 1 ] || { cat d3.log; fail "no single decompose summary"; }
echo "decompose on 3 ranks: $(wc -l < d1.list) files, byte-equal to one process"

# a broken file fails the job: tex/sub/bad.png is input 4 of the sorted listing (s0..s3 first), rank 1's
echo "not an image" > tex/sub/bad.png
rc=0
mpi 3 "$HDNET" $E -o bad > bad.log 2> bad.err || rc=$?
[ $rc -eq 1 ] || { cat bad.log bad.err; fail "a broken file on one rank: exit $rc, expected 1"; }
[ "$(grep -c '^estimate-light: 9 photos -> bad: 8 done (8 faces), 0 without a face, 1 failed' bad.log)" -eq 1 ] \
    || { cat bad.log bad.err; fail "the job's summary does not count the broken file once"; }
grep -q 'tex/sub/bad.png' bad.err || { cat bad.err; fail "the broken file was not reported"; }
[ "$(ls bad | wc -l)" -eq 5 ] && [ "$(ls bad/sub | wc -l)" -eq 4 ] || fail "the other 8 outputs were not all written"
echo "a broken file on rank 1: exit 1, one summary: $(grep '^estimate-light' bad.log)"
rm tex/sub/bad.png

# more ranks than inputs: one file to one output file, rank 0 does it, the others have none
mpi 3 "$HDNET" estimate-light tex/s0.png --aligned -m m.safetensors -o s0.light.txt > few.log 2>&1 \
    || { cat few.log; fail "one input on 3 ranks failed"; }
cmp -s s0.light.txt one/s0.light.txt || fail "one input on 3 ranks: a different light"
[ "$(grep -c 'estimated the light of 1 face' few.log)" -eq 1 ] || { cat few.log; fail "one input on 3 ranks: not one report"; }
echo "mpi batch: all checks passed"
