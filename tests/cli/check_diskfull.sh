#!/bin/sh
# SPDX-License-Identifier: MIT
# Full disks (issue 16), on small tmpfs mounts: a run whose output or checkpoint fills the disk
# keeps its last checkpoint and the rows it needs, says so with the system's reason, and after
# space is freed --resume writes the bytes of an uninterrupted run; a checkpoint path that cannot be
# written is found before the first step; a resume onto a full disk is a write error, not a short
# input. Needs root (mount -t tmpfs); exits 77 (skipped) where mounting is not permitted.
# usage: check_diskfull.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
P=$2/scenes/pendulum.ini
T=$(mktemp -d /tmp/dth_diskfull_test.XXXXXX)
mkdir "$T/fs" "$T/fs2"
cleanup() {
    umount "$T/fs" 2>/dev/null
    umount "$T/fs2" 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT
if ! mount -t tmpfs -o size=256k tmpfs "$T/fs" 2>/dev/null; then
    echo "skipped: mount -t tmpfs is not permitted here"
    exit 77
fi
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }
temps() { ls "$1" | grep -c '\.tmp\.'; }

# ---- the output's disk fills during a checkpointed run (6000 steps: 0.84 MB of CSV on 256 kB)
"$DTH" run "$P" -s integrator.steps=6000 -o "$T/ref.csv" 2>/dev/null || fail "reference run"
"$DTH" run "$P" -s integrator.steps=6000 -o "$T/fs/o.csv" --checkpoint "$T/fs/c.ckpt" --checkpoint-every 200 2>"$T/a.err"
rc=$?
[ $rc -eq 1 ] || fail "full disk: exit $rc, want 1"
grep -q "No space left on device" "$T/a.err" || fail "full disk: no reason given: $(cat "$T/a.err")"
grep -q "Success" "$T/a.err" && fail "full disk: 'Success' as the reason"
grep -q "and the rows it needs are kept: dth run --resume $T/fs/c.ckpt" "$T/a.err" || fail "full disk: no resume hint: $(cat "$T/a.err")"
[ "$(temps "$T/fs")" -eq 1 ] || fail "full disk: the temporary the checkpoint needs is gone ($(ls "$T/fs"))"
mount -o remount,size=4m "$T/fs" || fail "remount"
"$DTH" run --resume "$T/fs/c.ckpt" --checkpoint "$T/fs/c.ckpt" 2>"$T/a2.err" || fail "resume after freeing space: $(cat "$T/a2.err")"
cmp -s "$T/ref.csv" "$T/fs/o.csv" || fail "resume after a full disk differs from the uninterrupted run"
[ "$(temps "$T/fs")" -eq 0 ] || fail "temporaries left after the resume: $(ls "$T/fs")"
ok "the output's disk full: checkpoint and rows kept, resume byte-identical"

# ---- the checkpoint's disk fills while the run goes on (the output elsewhere): 4 kB free hold
# the first checkpoint (the start), not the next one beside it (it replaces the first by rename)
umount "$T/fs"
mount -t tmpfs -o size=64k tmpfs "$T/fs2" || fail "mount 2"
dd if=/dev/zero of="$T/fs2/filler" bs=4k count=15 2>/dev/null
"$DTH" run "$P" -s integrator.steps=3000 -o "$T/ref2.csv" 2>/dev/null || fail "reference run 2"
"$DTH" run "$P" -s integrator.steps=3000 -o "$T/o2.csv" --checkpoint "$T/fs2/c.ckpt" --checkpoint-every 1000 2>"$T/b.err"
rc=$?
[ $rc -eq 1 ] || fail "checkpoint disk full: exit $rc, want 1 ($(cat "$T/b.err"))"
grep -q "cannot write checkpoint '$T/fs2/c.ckpt': No space left on device" "$T/b.err" ||
    fail "checkpoint disk full: message $(cat "$T/b.err")"
grep -q "the checkpoint '$T/fs2/c.ckpt' of step 0 and the rows it needs are kept" "$T/b.err" ||
    fail "checkpoint disk full: no resume hint: $(cat "$T/b.err")"
ls "$T" | grep -q '^o2\.csv\.tmp\.' || fail "checkpoint disk full: the CSV the last checkpoint needs was removed"
rm -f "$T/fs2/filler"
"$DTH" run --resume "$T/fs2/c.ckpt" 2>"$T/b2.err" || fail "resume after the checkpoint's disk was freed: $(cat "$T/b2.err")"
cmp -s "$T/ref2.csv" "$T/o2.csv" || fail "resume after the checkpoint's disk was full differs"
ls "$T" | grep -q '\.tmp\.' && fail "temporaries left: $(ls "$T")"
ok "the checkpoint's disk full: last checkpoint and rows kept, resume byte-identical"

# ---- a checkpoint path that cannot be written is found before the first step
rm -f "$T/fs2/c.ckpt"
dd if=/dev/zero of="$T/fs2/filler" bs=4k count=100 2>/dev/null
"$DTH" run "$P" -s integrator.steps=100 -o "$T/p.csv" --checkpoint "$T/fs2/c.ckpt" 2>"$T/c.err"
rc=$?
[ $rc -eq 2 ] || fail "probe: exit $rc, want 2 ($(cat "$T/c.err"))"
grep -q "cannot write checkpoint '$T/fs2/c.ckpt': No space left on device" "$T/c.err" || fail "probe message: $(cat "$T/c.err")"
[ -e "$T/p.csv" ] && fail "probe: an output file was made"
ls "$T" | grep -q '^p\.csv\.tmp' && fail "probe: a temporary is left"
ok "an unwritable checkpoint path is found before the first step"

# ---- a resume onto a full disk: a write error (exit 1), not a short input
"$DTH" run "$P" -s integrator.steps=3000 -o "$T/r.csv" --checkpoint "$T/r.ckpt" 2>/dev/null || fail "run to resume"
"$DTH" run --resume "$T/r.ckpt" -s integrator.steps=4000 -o "$T/fs2/r.csv" 2>"$T/d.err"
rc=$?
[ $rc -eq 1 ] || fail "resume onto a full disk: exit $rc, want 1 ($(cat "$T/d.err"))"
grep -q "cannot write '$T/fs2/r.csv': No space left on device" "$T/d.err" || fail "resume onto a full disk: $(cat "$T/d.err")"
grep -q "shorter" "$T/d.err" && fail "resume onto a full disk reported as a short input"
ok "a resume onto a full disk is a write error"

[ $fails -eq 0 ] || { echo "$fails failure(s)" >&2; exit 1; }
echo "all disk-full checks passed"
