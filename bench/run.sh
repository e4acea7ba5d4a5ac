#!/usr/bin/env bash
# rendr vs Teem, same machine, same run: samples per second of teem-mrender and
# rendr go (value/max and gradmag/max; tent, bspln3, c4hexic), frame time of
# teem-miter and rendr go for an over + lit colour rendering, with 1 and 2 threads,
# plus how rendr's cost grows with pixels and samples per ray, rendr's two engines
# (the default reference arithmetic and -ref false, the f64 engine) against Teem, inside
# samples per second against this machine's peak, and VTK's fixed-point ray caster.
# Usage: bench/run.sh   (prints markdown; needs teem-apps and ../shared)
#        ONLY=ref bench/run.sh   (only the engines section)
#        ONLY=rate bench/run.sh  (only inside samples per second against the machine's peak)
#        ONLY=vtk bench/run.sh   (only VTK's ray caster; bench/setup-vtk.sh makes its Python)
#        ONLY=threads bench/run.sh   (only rendr's 2-thread speed-up)
#        ENGINE=false bench/run.sh   (the main sections with go -ref false)
#        MAP=0 bench/run.sh   (rendr reads the volumes into memory rather than mapping them)
#        RND_AVX512=0 bench/run.sh   (rendr without AVX-512, as on an AVX2-only processor;
#                                     RND_AVX2=0: SSE2 only; the Machine section says which)
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
(cd "$top" && cargo build --release -q -p rendr)
R="$top/target/release/rendr"
ENGINE=${ENGINE:-true}
CT="$top/../shared/volumes/imageio-stent-ct.nrrd"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

best() { # best-of-3 wall time of a command, seconds
  local b=1e9
  for _ in 1 2 3; do
    local t0 t1
    t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N)
    b=$(awk -v a="$b" -v x="$t0" -v y="$t1" 'BEGIN { d = y - x; print (d < a ? d : a) }')
  done
  echo "$b"
}

# Best wall times of two commands (strings, run with eval) run alternately, so that
# the slow and fast spells of this shared machine hit both: REPS rounds of one run of
# the first (Teem) and two of the second (rendr: its runs are short, and a one-off
# stall of this virtual machine, e.g. ~0.2 s to back fresh memory, would otherwise
# decide its time); prints "a b".
pair() {
  local ba=1e9 bb=1e9 t0 t1
  for _ in $(seq 1 "${REPS:-4}"); do
    t0=$(date +%s.%N); eval "$1" >/dev/null 2>&1; t1=$(date +%s.%N)
    ba=$(awk -v a="$ba" -v x="$t0" -v y="$t1" 'BEGIN { d = y - x; print (d < a ? d : a) }')
    for _ in 1 2; do
      t0=$(date +%s.%N); eval "$2" >/dev/null 2>&1; t1=$(date +%s.%N)
      bb=$(awk -v a="$bb" -v x="$t0" -v y="$t1" 'BEGIN { d = y - x; print (d < a ? d : a) }')
    done
  done
  echo "$ba $bb"
}

render_time() { # render seconds reported by rendr go under RND_VERBOSE=1
  RND_VERBOSE=1 "$@" 2>&1 >/dev/null | awk '/seconds to render/ { print $3 }'
}
min() { awk -v a="$1" -v x="$2" 'BEGIN { print (x < a ? x : a) }'; }

# The colour LUT and light of the `over` renderings (rendr and Teem read the same table).
printf '#space:=rgb\n0 1 0.9 0.8\n2000 1 0.6 0.5\n' > c.txt
printf '#space:=alpha\n0 0\n300 0\n600 0.2\n2000 1\n' > a.txt
"$R" lgen -i c.txt a.txt -mm 0 2000 -l 1024 -o lut.nrrd
teem-unu axinfo -i lut.nrrd -a 0 -l RGBA | teem-unu axinfo -a 1 -l "gage(scalar:v)" -o txf.nrrd
printf '#space:=rgb\n1 1 1  0 0 1  1\n' > lit.txt

# Volumes: the real CT (128x128x256 short; it records no geometry, so `unu dnorm` gives
# both programs the same identity orientation) and a 256^3 synthetic float (raw, so
# decompression does not dominate the timings), each a detached header (.nhdr) beside
# its raw data, as large volumes are often kept: rendr maps such data in place (set
# MAP=0 to have it read them into memory, as Teem does).
teem-unu dnorm -i "$CT" -o ct.nhdr
CT=ct.nhdr
"$R" sdg -w 12 -sz 256 256 256 -l 256 256 256 -o - | teem-unu save -f nrrd -e raw -o syn.nhdr
if [ "${MAP:-1}" = 0 ]; then export RENDR_MMAP=0; fi
# Orthographic cameras, image-plane extent 260 x 260 (world units) at distance 400.
fov=$(awk 'BEGIN { print 2 * atan2(130, 400) * 180 / 3.14159265358979 }')
SZ=${SZ:-256}
STEP=${STEP:-1}
N=$(awk -v s="$STEP" 'BEGIN { print int(260 / s + 1e-9) + 1 }')
samples=$((SZ * SZ * N))

declare -A AT=( [ct]="63.5 63.5 127.5" [syn]="0 0 0" )
# Fail loudly rather than time an error.
teem-mrender -i "$CT" -k scalar -fr 63.5 -336.5 127.5 -at 63.5 63.5 127.5 -up 0 0 1 -or -ar \
  -dn -130 -di 0 -df 130 -ur -130 130 -vr -130 130 -is 8 8 -q v -m max -step 1 -o check.nrrd
declare -A VOL=( [ct]="$CT" [syn]="syn.nhdr" )
echo "## Machine"
echo
echo "- CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores"
# The model number and caches tell machines with one name apart (their ratios differ).
cpuid=$(awk -F': *' '/^cpu family/ { f = $2 } /^model\t/ { m = $2 } /^stepping/ { s = $2; exit }
  END { printf "family %s model %s stepping %s", f, m, s }' /proc/cpuinfo)
caches=$(lscpu 2>/dev/null | awk -F': *' '/^L1d cache|^L2 cache|^L3 cache/ { sub(/ cache/, "", $1); printf "%s%s %s", sep, $1, $2; sep = ", " }')
echo "- CPUID: $cpuid; caches: ${caches:-unknown}"
echo "- $(teem-unu --version 2>/dev/null | head -1 || echo 'Teem (Debian teem-apps)'); rendr $(git -C "$top" rev-parse --short HEAD)"
echo "- go engine in the main sections: -ref $ENGINE"
# RND_AVX2=0 / RND_AVX512=0 turn rendr's wider vector paths off: say which it uses.
echo "- rendr's vector paths: $("$R" about | awk '/^Vector paths in use:/ { sub(/^Vector paths in use: /, ""); sub(/ \(.*/, ""); print }')"
# This shared machine has slow spells that slow Teem and rendr unequally (RESULTS.md runs
# 64, 65): one core's peak before and after the run shows whether it ran in one.
# `peak` prints one line a measurement (`cargo bench -p rnd-tests --bench peak`).
peak() { (cd "$top" && cargo bench -q -p rnd-tests --bench peak 2>/dev/null); }
peak_line() { peak | tr '\n' ';' | sed 's/;$//; s/;/; /g'; }
echo "- one core's peak before the run: $(peak_line)"
echo
if [ "${ONLY:-all}" = all ]; then
echo "## Samples per second, teem-mrender vs rendr go (orthographic, ${SZ}x${SZ}, $N samples per ray = $samples samples; whole commands, best of ${REPS:-4} Teem and $((2 * ${REPS:-4})) rendr runs, alternating)"
echo
echo "| volume | kernel | query | threads | Teem s | rendr s | Teem Msamples/s | rendr Msamples/s | ratio |"
echo "|---|---|---|---|---|---|---|---|---|"
for v in ct syn; do
  at=(${AT[$v]})
  fr="${at[0]} $(awk -v y="${at[1]}" 'BEGIN { print y - 400 }') ${at[2]}"
  for k in tent bspln3 c4hexic; do
    for q in v gm; do
      for nt in 1 2; do
        read -r tt rt < <(pair \
          "teem-mrender -i ${VOL[$v]} -k scalar -fr $fr -at ${AT[$v]} -up 0 0 1 -or -ar \
             -dn -130 -di 0 -df 130 -ur -130 130 -vr -130 130 -is $SZ $SZ \
             -k00 $k -k11 ${k}d -k22 zero -q $q -m max -step $STEP -nt $nt -o t.nrrd" \
          "$R go -i ${VOL[$v]} -fr $fr -at ${AT[$v]} -up 0 0 1 -ortho -nc -130 -fc 130 \
             -fov $fov -sz $SZ $SZ -k $k -p $q -b max -s $STEP -nt $nt -ref $ENGINE -sp false -o r.nrrd")
        awk -v v="$v" -v k="$k" -v q="$q" -v nt="$nt" -v tt="$tt" -v rt="$rt" -v n="$samples" 'BEGIN {
          printf "| %s | %s | %s/max | %d | %.3f | %.3f | %.1f | %.1f | %.1fx |\n", v, k, q, nt, tt, rt, n / tt / 1e6, n / rt / 1e6, tt / rt }'
      done
    done
  done
done

fi

if [ "${ONLY:-all}" = all ] || [ "${ONLY:-all}" = threads ]; then
echo
ROUNDS2=${ROUNDS2:-9}
echo "## rendr's 2-thread speed-up of the render phase (bspln3 MIPs, and the CT's lit \`over\` of the teem-miter section; RND_VERBOSE render time, volume reading excluded; best of $ROUNDS2 rounds, runs alternating)"
echo
echo "Each round runs the render with 1 thread, with 2 threads, and, as a control of what"
echo "this machine gives two busy cores at that moment, two independent 1-thread renders at"
echo "once (two processes, no shared work). 'Machine' is 2 × (1-thread time) / (the slower"
echo "of the two concurrent 1-thread renders): the speed-up of perfectly independent work."
echo
echo "Best-of times give the first columns; the last two are the medians, over the rounds, of"
echo "each round's own ratios (1- and 2-thread runs a second apart), less swayed by spells."
echo "'≥ 1.9×' reads the medians against #17's target, 2 threads at least 1.9× one where the"
echo "machine's own control allows it: met or not where the median machine is ≥ 1.9×, else"
echo "'control below' (the machine gave less than 1.9× to independent work then)."
echo
echo "| volume | rendering | 1 thread s | 2 threads s | speed-up | two 1-thread renders at once s | machine | median speed-up | median machine | ≥ 1.9× |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for v in ct syn; do
  at=(${AT[$v]})
  fr="${at[0]} $(awk -v y="${at[1]}" 'BEGIN { print y - 400 }') ${at[2]}"
  qs="v gm"; [ "$v" = ct ] && qs="v gm over:tent over:bspln3"
  for q in $qs; do
    what=(-k bspln3 -p $q -b max)
    if [ "${q%%:*}" = over ]; then
      what=(-k "${q#over:}" -p rgbalit -b over -us $STEP -a1 0.99 -lut lut.nrrd -lit lit.txt -ph 0.2 0.8 0.1 150)
    fi
    go=(go -i "${VOL[$v]}" -fr $fr -at ${AT[$v]} -up 0 0 1 -ortho -nc -130 -fc 130 \
        -fov "$fov" -sz $SZ $SZ "${what[@]}" -s $STEP -ref "$ENGINE" -sp false)
    # 1- and 2-thread runs and the control alternate (so slow drifts of this shared
    # machine hit all three); best of ROUNDS2 each.
    b1=1e9; b2=1e9; bp=1e9
    : >rounds.txt
    for _ in $(seq 1 "$ROUNDS2"); do
      t1=$(render_time "$R" "${go[@]}" -nt 1 -o r.nrrd)
      t2=$(render_time "$R" "${go[@]}" -nt 2 -o r.nrrd)
      render_time "$R" "${go[@]}" -nt 1 -o ra.nrrd >pa.txt &
      render_time "$R" "${go[@]}" -nt 1 -o rb.nrrd >pb.txt
      wait
      tp=$(cat pa.txt pb.txt | sort -g | tail -1)
      b1=$(min "$b1" "$t1"); b2=$(min "$b2" "$t2"); bp=$(min "$bp" "$tp")
      echo "$t1 $t2 $tp" >>rounds.txt
    done
    med() { sort -g | awk '{ x[NR] = $1 } END { print (NR % 2 ? x[(NR + 1) / 2] : (x[NR / 2] + x[NR / 2 + 1]) / 2) }'; }
    ms=$(awk '{ print $1 / $2 }' rounds.txt | med)
    mm=$(awk '{ print 2 * $1 / $3 }' rounds.txt | med)
    awk -v v="$v" -v q="$q" -v a="$b1" -v b="$b2" -v p="$bp" -v ms="$ms" -v mm="$mm" 'BEGIN {
      r = (q ~ /^over:/) ? "rgbalit/over " substr(q, 6) : q "/max"
      # (Read as printed, to two decimals.)
      msr = sprintf("%.2f", ms) + 0; mmr = sprintf("%.2f", mm) + 0
      verdict = (mmr < 1.9) ? "control below" : (msr >= 1.9 ? "met" : "not met")
      printf "| %s | %s | %.3f | %.3f | %.2fx | %.3f | %.2fx | %.2fx | %.2fx | %s |\n", v, r, a, b, a / b, p, 2 * a / p, ms, mm, verdict }'
  done
done

fi

if [ "${ONLY:-all}" = all ]; then
echo
echo "## Frame time, teem-miter vs rendr go (CT, colour LUT + Blinn-Phong, over, early termination 0.99; whole commands, best of 6 Teem and 12 rendr runs, alternating)"
echo
echo "| kernel | threads | Teem s | rendr s | ratio |"
echo "|---|---|---|---|---|"
at=(${AT[ct]})
fr="${at[0]} $(awk -v y="${at[1]}" 'BEGIN { print y - 400 }') ${at[2]}"
for k in tent bspln3; do
  for nt in 1 2; do
    read -r tt rt < <(REPS=6 pair \
      "teem-miter -i $CT -txf txf.nrrd -fr $fr -at ${AT[ct]} -up 0 0 1 -or -ar -dn -130 -di 0 -df 130 \
         -ur -130 130 -vr -130 130 -is $SZ $SZ -k00 $k -k11 ${k}d -k22 zero -step $STEP -ref $STEP \
         -n1 0.99 -ld 0 0 1 -ads 0.2 0.8 0.1 -sp 150 -nt $nt -o t.nrrd" \
      "$R go -i $CT -fr $fr -at ${AT[ct]} -up 0 0 1 -ortho -nc -130 -fc 130 -fov $fov \
         -sz $SZ $SZ -k $k -p rgbalit -b over -s $STEP -us $STEP -a1 0.99 -lut lut.nrrd -lit lit.txt \
         -ph 0.2 0.8 0.1 150 -nt $nt -ref $ENGINE -sp false -o r.nrrd")
    awk -v k="$k" -v nt="$nt" -v tt="$tt" -v rt="$rt" 'BEGIN { printf "| %s | %d | %.3f | %.3f | %.1fx |\n", k, nt, tt, rt, tt / rt }'
  done
done

echo
echo "## How rendr's cost grows (CT, bspln3, value/max, 1 thread)"
echo
echo "Whole command (best of 3 wall times) and render phase alone (RND_VERBOSE, best of 3)."
echo
echo "| image | step | samples | command s | render s | render ns/sample |"
echo "|---|---|---|---|---|---|"
for cfg in "128 1" "256 1" "512 1" "256 2" "256 0.5" "256 0.25"; do
  set -- $cfg
  n=$(awk -v s="$2" 'BEGIN { print int(260 / s + 1e-9) + 1 }')
  ns=$(( $1 * $1 * n ))
  args=(go -i "$CT" -fr $fr -at ${AT[ct]} -up 0 0 1 -ortho -nc -130 -fc 130 -fov "$fov"
        -sz $1 $1 -k bspln3 -p v -b max -s $2 -nt 1 -ref "$ENGINE" -sp false -o r.nrrd)
  rt=$(best "$R" "${args[@]}")
  rr=1e9
  for _ in 1 2 3; do
    t=$(render_time "$R" "${args[@]}")
    rr=$(awk -v a="$rr" -v x="$t" 'BEGIN { print (x < a ? x : a) }')
  done
  awk -v a="$1" -v s="$2" -v n="$ns" -v t="$rt" -v r="$rr" 'BEGIN { printf "| %dx%d | %s | %d | %.3f | %.3f | %.2f |\n", a, a, s, n, t, r, r / n * 1e9 }'
done
fi

if [ "${ONLY:-all}" = all ] || [ "${ONLY:-all}" = ref ]; then
echo
echo "## Engines: rendr go (default: the reference arithmetic) and go -ref false (the f64 engine) vs Teem (bspln3, 1 thread; best of ${REPS:-4} Teem and $((2 * ${REPS:-4})) rendr runs, alternating)"
echo
echo "| volume | rendering | Teem s | rendr s | rendr -ref false s | Teem / rendr | Teem / -ref false | rendr / -ref false |"
echo "|---|---|---|---|---|---|---|---|"
for v in ct syn; do
  at=(${AT[$v]})
  fr="${at[0]} $(awk -v y="${at[1]}" 'BEGIN { print y - 400 }') ${at[2]}"
  for q in v gm; do
    mr="teem-mrender -i ${VOL[$v]} -k scalar -fr $fr -at ${AT[$v]} -up 0 0 1 -or -ar \
        -dn -130 -di 0 -df 130 -ur -130 130 -vr -130 130 -is $SZ $SZ \
        -k00 bspln3 -k11 bspln3d -k22 zero -q $q -m max -step $STEP -nt 1 -o t.nrrd"
    go="$R go -i ${VOL[$v]} -fr $fr -at ${AT[$v]} -up 0 0 1 -ortho -nc -130 -fc 130 \
        -fov $fov -sz $SZ $SZ -k bspln3 -p $q -b max -s $STEP -nt 1 -sp false -o r.nrrd"
    read -r tt rt < <(pair "$mr" "$go")
    read -r _ ft < <(pair "$mr" "$go -ref false")
    awk -v v="$v" -v q="$q" -v tt="$tt" -v rt="$rt" -v ft="$ft" 'BEGIN {
      printf "| %s | %s/max | %.3f | %.3f | %.3f | %.1fx | %.1fx | %.2fx |\n", v, q, tt, rt, ft, tt / rt, tt / ft, rt / ft }'
  done
done
at=(${AT[ct]})
fr="${at[0]} $(awk -v y="${at[1]}" 'BEGIN { print y - 400 }') ${at[2]}"
mi="teem-miter -i $CT -txf txf.nrrd -fr $fr -at ${AT[ct]} -up 0 0 1 -or -ar -dn -130 -di 0 -df 130 \
    -ur -130 130 -vr -130 130 -is $SZ $SZ -k00 bspln3 -k11 bspln3d -k22 zero -step $STEP -ref $STEP \
    -n1 0.99 -ld 0 0 1 -ads 0.2 0.8 0.1 -sp 150 -nt 1 -o t.nrrd"
go="$R go -i $CT -fr $fr -at ${AT[ct]} -up 0 0 1 -ortho -nc -130 -fc 130 -fov $fov \
    -sz $SZ $SZ -k bspln3 -p rgbalit -b over -s $STEP -us $STEP -a1 0.99 -lut lut.nrrd -lit lit.txt \
    -ph 0.2 0.8 0.1 150 -nt 1 -sp false -o r.nrrd"
read -r tt rt < <(REPS=6 pair "$mi" "$go")
read -r _ ft < <(REPS=6 pair "$mi" "$go -ref false")
awk -v tt="$tt" -v rt="$rt" -v ft="$ft" 'BEGIN {
  printf "| ct | rgbalit/over (teem-miter) | %.3f | %.3f | %.3f | %.1fx | %.1fx | %.2fx |\n", tt, rt, ft, tt / rt, tt / ft, rt / ft }'
fi

if [ "${ONLY:-all}" = all ] || [ "${ONLY:-all}" = rate ]; then
echo
echo "## Inside samples per second per core, against this machine's peak (1 thread, bspln3 unless named)"
echo
echo "Inside samples: the ray samples whose kernel support lies in the volume (the work of a"
echo "renderer without skipping or early termination; counted with \`go -p in -b sum\`), over"
echo "the render phase (RND_VERBOSE, best of 3). The peak is one core's f32 throughput"
echo "(\`cargo bench -p rnd-tests --bench peak\`, best of 5): rendr's bit-exact sums use"
echo "separate multiplies and adds (no FMA), so 'mul+add' is its ceiling."
echo
peak | sed 's/^/- /'
echo
echo "| volume | rendering | inside samples | render s | inside Msamples/s |"
echo "|---|---|---|---|---|"
for v in ct syn; do
  at=(${AT[$v]})
  fr="${at[0]} $(awk -v y="${at[1]}" 'BEGIN { print y - 400 }') ${at[2]}"
  cam=(-i "${VOL[$v]}" -fr $fr -at ${AT[$v]} -up 0 0 1 -ortho -nc -130 -fc 130 -fov "$fov" -sz $SZ $SZ -s $STEP -nt 1 -ref "$ENGINE" -sp false)
  cases=("bspln3 v max" "bspln3 gm max")
  [ "$v" = ct ] && cases+=("tent rgbalit over" "bspln3 rgbalit over")
  for c in "${cases[@]}"; do
    set -- $c
    inside=$("$R" go "${cam[@]}" -k "$1" -p in -b sum -o - | teem-unu project -a 0 -m sum | teem-unu save -f text | awk '{ for (i = 1; i <= NF; i++) s += $i } END { printf "%d", s }')
    extra=()
    [ "$3" = over ] && extra=(-us $STEP -a1 0.99 -lut lut.nrrd -lit lit.txt -ph 0.2 0.8 0.1 150)
    rr=1e9
    for _ in 1 2 3; do
      t=$(render_time "$R" go "${cam[@]}" -k "$1" -p "$2" -b "$3" "${extra[@]}" -o r.nrrd)
      rr=$(min "$rr" "$t")
    done
    awk -v v="$v" -v c="$2/$3 $1" -v n="$inside" -v r="$rr" 'BEGIN { printf "| %s | %s | %d | %.3f | %.0f |\n", v, c, n, r, n / r / 1e6 }'
  done
done
fi

if [ "${ONLY:-all}" = all ] || [ "${ONLY:-all}" = vtk ]; then
echo
echo "## VTK's fixed-point CPU ray caster vs rendr go (CT, ${SZ}x${SZ}, step $STEP, 1 thread)"
echo
VTK_PY=${VTK_PY:-$top/bench/.venv/bin/python}
if ! "$VTK_PY" -c 'import vtk, numpy' 2>/dev/null; then
  echo "skipped: no Python with vtk and numpy at $VTK_PY (make one with bench/setup-vtk.sh)"
else
echo "VTK $("$VTK_PY" -c 'import vtk; print(vtk.vtkVersion.GetVTKVersion())') from PyPI, offscreen through OSMesa"
echo "(bench/vtk_raycast.py): vtkFixedPointVolumeRayCastMapper, trilinear (VTK has no B-spline"
echo "reconstruction), 15-bit fixed-point arithmetic, space leaping, precomputed normals. Its first"
echo "frame includes computing those; later frames (best of 5) reuse them. rendr: whole"
echo "command (reading the file included, best of 3) and render phase (best of 3), every frame"
echo "computed from scratch; and its later frames: \`rendr turn -n 6 -deg 0\` renders the same view"
echo "six times, frames 2-6 reusing the skip grid the volume keeps (the grid's windows are aimed"
echo "at the camera every frame), best of those of 2 runs. Ratios: VTK time / rendr time (above"
echo "1: rendr is faster)."
echo
echo "Two views: along the volume's y axis (the rest of the benchmark's view) and an oblique one"
echo "(looking from the direction (0.48, -0.8, 0.36)), where no axis of the volume runs along the rays."
echo
echo "| view | rendering | rendr kernel | VTK first s | VTK later s | rendr command s | rendr render s | rendr later s | later / render | later / later |"
echo "|---|---|---|---|---|---|---|---|---|---|"
teem-unu save -f nrrd -e raw -i "$CT" -o ctraw.nrrd
at=(${AT[ct]})
for view in axis oblique; do
if [ $view = axis ]; then
  fr="${at[0]} $(awk -v y="${at[1]}" 'BEGIN { print y - 400 }') ${at[2]}"
else
  fr=$(awk -v x="${at[0]}" -v y="${at[1]}" -v z="${at[2]}" 'BEGIN { print x + 192, y - 320, z + 144 }')
fi
for c in "mip tent" "mip bspln3" "over tent" "over bspln3"; do
  set -- $c
  read -r vf vl < <(VTK_DEFAULT_OPENGL_WINDOW=vtkOSOpenGLRenderWindow "$VTK_PY" "$top/bench/vtk_raycast.py" \
    ctraw.nrrd "$1" "$SZ" "$STEP" 1 "$fr" "${AT[ct]}" "0 0 1")
  if [ "$1" = mip ]; then what=(-p v -b max); else
    what=(-p rgbalit -b over -us $STEP -a1 0.99 -lut lut.nrrd -lit lit.txt -ph 0.2 0.8 0.1 150); fi
  args=(go -i "$CT" -fr $fr -at ${AT[ct]} -up 0 0 1 -ortho -nc -130 -fc 130 -fov "$fov" \
        -sz $SZ $SZ -k "$2" "${what[@]}" -s $STEP -nt 1 -ref "$ENGINE" -o r.nrrd)
  rc=$(best "$R" "${args[@]}")
  rr=1e9
  for _ in 1 2 3; do rr=$(min "$rr" "$(render_time "$R" "${args[@]}")"); done
  # The same render as six frames of a turntable that does not turn.
  targs=(turn "${args[@]:1:${#args[@]}-3}" -n 6 -deg 0 -f nrrd -o t)
  rl=1e9
  for _ in 1 2; do
    t=$(RND_VERBOSE=1 "$R" "${targs[@]}" 2>&1 >/dev/null | awk '/frame [1-9][0-9]*:/ { print $5 }' | sort -g | head -1)
    rl=$(min "$rl" "$t")
  done
  awk -v w="$view" -v c="$1" -v k="$2" -v vf="$vf" -v vl="$vl" -v rc="$rc" -v rr="$rr" -v rl="$rl" 'BEGIN {
    printf "| %s | %s | %s | %.3f | %.3f | %.3f | %.3f | %.3f | %.2fx | %.2fx |\n", w, (c == "mip" ? "v/max" : "rgbalit/over"), k, vf, vl, rc, rr, rl, vl / rr, vl / rl }'
done
done
fi
fi

echo
echo "One core's peak after the run: $(peak_line)"
