#!/bin/sh
# pipelines/slurm/submit without Slurm, so that it is tested wherever the
# cluster tests (tests/cluster/run.sh) SKIP: usage errors, the plan -n
# prints, --local rendering a small turntable, and the plan again after
# outputs are deleted, truncated or corrupted: only what is missing or
# invalid, and what follows it.
# Run from the repository root: sh tests/cli/cluster.sh
. tests/harness.sh
B=${BIN:-bin}
PM_BIN=$(cd "$B" && pwd)
export PM_BIN
submit=pipelines/slurm/submit
scene=data/bunny.xml
grep -v '^[[:space:]]*\(#\|$\)' data/turntable.cams | head -n 2 >"$tmp/cams"
P="--shards 2 --photons 4000 --spp 1 --size 16x16 --cameras $tmp/cams"
# plan: submit -n's lines, one string
plan() { sh $submit -n $P -o "$tmp/r" $scene 2>&1 | tr '\n' ';'; }

check "--help exits 0" status 0 sh $submit --help
check "...printing the usage on stdout" grep -q '^usage: submit' "$tmp/out"
check "no output directory exits 2" status 2 sh $submit $scene
check "...saying so" grep -q 'no output directory' "$tmp/err"
check "an unknown option exits 2" status 2 sh $submit --frobnicate -o "$tmp/x" $scene
check "--cameras with --passes exits 2" status 2 sh $submit --cameras "$tmp/cams" --passes 2 -o "$tmp/x" $scene
check "fewer photon paths than shards exits 2" status 2 sh $submit --shards 8 --photons 7 -o "$tmp/x" $scene
check "--shards x exits 2" status 2 sh $submit --shards x -o "$tmp/x" $scene
check "a missing scene exits 1" status 1 sh $submit -o "$tmp/x" "$tmp/none.xml"

check "-n plans every stage" same "$(plan)" \
    "shoot [1-2];balance after shoot;render [1-2] after balance;final after render;"
check "...and writes nothing" test ! -e "$tmp/r"
check "-n --passes plans the passes and the mean" same \
    "$(sh $submit -n --passes 3 --photons 4000 -o "$tmp/p" $scene | tr '\n' ';')" \
    "pass [1-3];final after pass;"
check "--local renders it" status 0 sh $submit --local $P -o "$tmp/r" $scene
check "...every stage" same "$(tr '\n' ';' <"$tmp/out")" \
    "shoot local 1-2;balance local;render local 1-2;final local;"
check "...a map that passes --verify" status 0 $B/pm-inspect --verify "$tmp/r/scene.pmap"
check "...and the PNGs" test -s "$tmp/r/frames/frame-01.png" -a -s "$tmp/r/frames/frame-02.png"
check "then nothing is left to do" same "$(plan)" \
    "submit: $(cd "$tmp/r" && pwd) is complete: nothing to submit;"
rm "$tmp/r/frames/frame-02.png"
check "a missing PNG: the final job only" same "$(plan)" "final;"
truncate -s 100 "$tmp/r/frames/frame-02.exr"
check "a truncated image: that frame, then the final job" same "$(plan)" \
    "render [2];final after render;"
printf '\001' | dd of="$tmp/r/scene.pmap" bs=1 seek=20000 conv=notrunc 2>/dev/null
check "a corrupt map too: the balance first" same "$(plan)" \
    "balance;render [2] after balance;final after render;"
head -c 5000 "$tmp/r/shards/shard-002.pmap" >"$tmp/s" && mv "$tmp/s" "$tmp/r/shards/shard-002.pmap"
check "a truncated shard too: that shard first" same "$(plan)" \
    "shoot [2];balance after shoot;render [2] after balance;final after render;"
check "--local redoes just that" status 0 sh $submit --local $P -o "$tmp/r" $scene
check "...shard 2, the balance, frame 2 and the final job" same "$(tr '\n' ';' <"$tmp/out")" \
    "shoot local 2;balance local;render local 2;final local;"
check "...which kept frame 1's PNG" grep -q 'kept frames/frame-01.png' "$tmp/r/logs/final-local.out"
check "...so nothing is left to do" same "$(plan)" \
    "submit: $(cd "$tmp/r" && pwd) is complete: nothing to submit;"
check "other parameters in the same directory exit 1" status 1 sh $submit -n $P --spp 2 -o "$tmp/r" $scene
check "...naming what differs" grep -q "SPP='2'" "$tmp/err"
finish cluster
