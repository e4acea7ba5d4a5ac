#!/usr/bin/env bash
# Bricked rendering under MPI (#23): per-rank peak memory and strong scaling of
# `mpirun -np N rendr go` on a 512^3 16-bit volume (256 MiB of samples, raw NRRD), and
# the check that every N gives the one-process image's data.
# Usage: bench/mpi.sh   (prints markdown; needs openmpi-bin libopenmpi-dev libclang-dev
#        and teem-apps; builds rendr --release --features mpi)
# This machine has 2 cores: N = 4 runs 4 processes on them (--oversubscribe); read its
# time as such.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
(cd "$top" && cargo build --release -q -p rendr --features mpi)
R="$top/target/release/rendr"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
MPI=(mpirun --oversubscribe)
[ "$(id -u)" = 0 ] && MPI+=(--allow-run-as-root)

"$R" sdg -w 12 -sz 512 512 512 -t short -vs 1 10000 -o ml-gz.nrrd
teem-unu save -f nrrd -e raw -i ml-gz.nrrd -o ml.nrrd
CAM=(-fr 4 3 2.5 -at 0 0 0 -up 0 0 1 -nc -3 -fc 3 -fov 25)

kb() { /usr/bin/time -f "%M" "$@" 2>&1 >/dev/null | tail -n 1; }
same() { # the data of two float NRRDs are equal (min = max = 0 of their difference)
  [ "$(teem-unu 2op - "$1" "$2" | teem-unu minmax - | awk '/^max:/ { print $2 }')" = 0 ] &&
    [ "$(teem-unu 2op - "$1" "$2" | teem-unu minmax - | awk '/^min:/ { print $2 }')" = 0 ]
}
best() { # best-of-3 wall time of a command, seconds
  local b=1e9 t0 t1
  for _ in 1 2 3; do
    t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N)
    b=$(awk -v a="$b" -v x="$t0" -v y="$t1" 'BEGIN { d = y - x; print (d < a ? d : a) }')
  done
  echo "$b"
}

echo "### Per-rank peak memory (bspln3 v/max, 256x256, -nt 1; /usr/bin/time %M)"
echo
echo "| file | processes | peak RSS per process (MiB) | of one process | image data |"
echo "|---|---|---|---|---|"
MIP=(-k bspln3 -p v -b max -s 0.005 -sz 256 256 -nt 1)
for f in ml.nrrd ml-gz.nrrd; do
  one=$(kb "$R" go -i "$f" "${CAM[@]}" "${MIP[@]}" -o one.nrrd)
  echo "| $f | 1 | $((one / 1024)) | 100% | reference |"
  for np in 2 4; do
    m=$("${MPI[@]}" -np "$np" /usr/bin/time -f "%M" "$R" go -i "$f" "${CAM[@]}" "${MIP[@]}" \
      -o "np$np.nrrd" 2>&1 | sort -n | tail -n 1)
    s=$(same one.nrrd "np$np.nrrd" && echo "identical" || echo "DIFFERS")
    echo "| $f | $np | $((m / 1024)) (largest) | $((100 * m / one))% | $s |"
  done
done
echo
echo "### Strong scaling (bspln3 v/sum, 512x512, step 0.002, -nt 1 per process; best of 3 wall times, reading the raw file included)"
echo
SUM=(-k bspln3 -p v -b sum -s 0.002 -sz 512 512)
"$R" go -i ml.nrrd "${CAM[@]}" -k bspln3 -p in -b sum -s 0.002 -sz 512 512 -o in.nrrd
inside=$(teem-unu project -i in.nrrd -a 0 -m sum | teem-unu project -a 0 -m sum |
  teem-unu project -a 0 -m sum | teem-unu save -f text | awk '{ printf "%d", $1 }')
echo "Inside samples: $inside."
echo
echo "| run | seconds | speed-up over one process | image data vs one process |"
echo "|---|---|---|---|"
"$R" go -i ml.nrrd "${CAM[@]}" "${SUM[@]}" -nt 1 -o s.nrrd
t1=$(best "$R" go -i ml.nrrd "${CAM[@]}" "${SUM[@]}" -nt 1 -o s.nrrd)
echo "| rendr go, 1 process, 1 thread | $t1 | 1.00 | reference |"
t=$(best "$R" go -i ml.nrrd "${CAM[@]}" "${SUM[@]}" -nt 2 -o s2t.nrrd)
echo "| rendr go, 1 process, 2 threads | $t | $(awk -v a="$t1" -v b="$t" 'BEGIN { printf "%.2f", a / b }') | - |"
for np in 1 2 4; do
  t=$(best "${MPI[@]}" -np "$np" "$R" go -i ml.nrrd "${CAM[@]}" "${SUM[@]}" -nt 1 -o "s$np.nrrd")
  d=$(teem-unu 2op - s.nrrd "s$np.nrrd" | teem-unu 1op abs | teem-unu 2op / - s.nrrd |
    teem-unu minmax - | awk '/^max:/ { print $2 }')
  echo "| mpirun -np $np | $t | $(awk -v a="$t1" -v b="$t" 'BEGIN { printf "%.2f", a / b }') | max relative difference $d |"
done
