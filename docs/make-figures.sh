#!/usr/bin/env bash
# Regenerates every figure of docs/VERIFICATION.md and the README gallery from the
# current code. Usage: docs/make-figures.sh [OUTDIR]   (default docs/figures)
# Needs only rendr (built here); a test re-runs it and checks the committed PNGs are
# byte-identical to what the code makes now.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
out=$(mkdir -p "${1:-$top/docs/figures}" && cd "${1:-$top/docs/figures}" && pwd)
R=${RENDR:-}
if [ -n "$R" ]; then
  R="$(cd "$(dirname "$R")" && pwd)/$(basename "$R")"
else
  (cd "$top" && cargo build --release -q -p rendr)
  R="$top/target/release/rendr"
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
go() { "$R" go -sp false -nt 2 "$@"; }

# ---------------------------------------------------------------- datasets
"$R" sdg -w 15 -sz 64 64 64 -l 2 2 2 -o marker.nrrd        # blobs at 0, +x, +z
"$R" sdg -w 13 -sz 48 48 48 -l 2 2 2 -o sphere.nrrd        # 1 - |p|, |grad| = 1
"$R" sdg -w 16 -sz 48 48 48 -l 2 2 2 -o sphere10.nrrd      # 10 (1 - |p|), |grad| = 10
"$R" sdg -w 2 -sz 64 64 64 -l 4 4 4 -o cube.nrrd            # the seed's cube
"$R" sdg -w 9 -sz 64 64 64 -l 2 2 2 -o ball.nrrd            # -(x^2+y^2+z^2)
"$R" sdg -w 11 -sz 20 20 20 -l 2 2 2 -o const.nrrd          # constant 1
printf -- '-fr 6 12 5 -at 0 0 0 -up 0 0 1\n-nc -2.56304 -fc 2.56304 -fov 16\n-sz 200 200\n' > cube-cam.txt
printf '#space:=alpha\n0.00 0\n0.80 0\n0.90 1\n1.00 1\n' > cube-atxf1.txt
printf '#space:=rgb\n1 0 0   1 0 0  0\n0 1 0   0 1 0  0\n0 0 1   0 0 1  0\n' > rgb.txt
printf '#space:=rgb\n1 1 1  -1 1 2  1\n' > white.txt
"$R" lgen -i x cube-atxf1.txt -mm 0 1 -o cube-lut.nrrd

# ---------------------------------------------------------------- 1. camera
# Marker seen from -y with up +z: +x blob to the right, +z blob above the centre.
go -i marker.nrrd -fr 0 -5 0 -at 0 0 0 -up 0 0 1 -nc -1.5 -fc 1.5 -fov 20 -sz 200 200 \
   -k bspln3 -s 0.01 -p v -b max -q 0 1 -o "$out/cam-marker.png"
# Same marker, up = +x: now the +x blob is above the centre.
go -i marker.nrrd -fr 0 -5 0 -at 0 0 0 -up 1 0 0 -nc -1.5 -fc 1.5 -fov 20 -sz 200 200 \
   -k bspln3 -s 0.01 -p v -b max -q 0 1 -o "$out/cam-marker-upx.png"
# Aspect ratio: a sphere in a 300x150 image stays round.
"$R" lgen -i x <(printf '#space:=alpha\n0.499 0\n0.5 1\n') -mm 0 1 -l 4096 -o sph-lut.nrrd
go -i sphere.nrrd -fr 0 0 6 -at 0 0 0 -up 0 1 0 -nc -1.2 -fc 1.2 -fov 20 -sz 300 150 \
   -k bspln3 -s 0.01 -us 0.01 -p rgbalit -b over -lut sph-lut.nrrd -lit white.txt -o "$out/cam-aspect.png"
# Field of view 14 vs 28 degrees: the sphere's image doubles (tan ratio 2.03).
for f in 14 28; do
  go -i sphere.nrrd -fr 0 0 6 -at 0 0 0 -up 0 1 0 -nc -1.2 -fc 1.2 -fov $f -sz 150 150 \
     -k bspln3 -s 0.01 -us 0.01 -p rgbalit -b over -lut sph-lut.nrrd -lit white.txt -o "$out/cam-fov$f.png"
done
# Near plane through the cube: the cut face shows the inside.
go @cube-cam.txt -i cube.nrrd -nc -0.5 -k ctmr -s 0.02 -us 0.02 -p rgbalit -b over \
   -lut cube-lut.nrrd -lit rgb.txt -o "$out/cam-near-cut.png"
# Perspective vs orthographic.
go @cube-cam.txt -i cube.nrrd -k ctmr -s 0.02 -us 0.02 -p rgbalit -b over \
   -lut cube-lut.nrrd -lit rgb.txt -o "$out/cam-persp.png"
go @cube-cam.txt -i cube.nrrd -k ctmr -s 0.02 -us 0.02 -p rgbalit -b over -ortho \
   -lut cube-lut.nrrd -lit rgb.txt -o "$out/cam-ortho.png"

# ---------------------------------------------------------------- 2. transfer functions
printf '#range:=alpha\n0 0\n1 1\n' > atxf.txt
printf '#range:=rgb\n0 0 1 0\n1 1 0 1\n' > ctxf-rgb.txt
printf '#range:=hsv\n0 0 1 1\n0.33 0.33 1 1\n0.66 0.66 1 1\n1 1 1 1\n' > ctxf-hsv.txt
for c in rgb hsv; do
  "$R" lgen -i ctxf-$c.txt atxf.txt -mm 0 1 -rs false false -h 40 -o l.nrrd -oi "$out/lut-$c-0.png"
  "$R" lgen -i ctxf-$c.txt atxf.txt -mm -2 3 -rs true true -h 40 -o l.nrrd -oi "$out/lut-$c-1.png"
  "$R" lgen -i ctxf-$c.txt atxf.txt -mm -2 3 -rs false true -h 40 -o l.nrrd -oi "$out/lut-$c-2.png"
  "$R" lgen -i ctxf-$c.txt atxf.txt -mm -2 3 -rs true false -h 40 -o l.nrrd -oi "$out/lut-$c-3.png"
  "$R" lgen -i ctxf-$c.txt atxf.txt -mm -2 3 -rs false false -h 40 -o l.nrrd -oi "$out/lut-$c-4.png"
done
# Levoy: the same shell on |grad| = 1 and |grad| = 10 data looks the same.
printf '#space:=rgb\n-100 1 1 1\n100 1 1 1\n' > white-ctxf.txt
"$R" lgen -i white-ctxf.txt x -mm -100 100 -o white-lut.nrrd
echo "0.5 0.02 0.8" > lev1.txt
echo "5 0.02 0.8" > lev10.txt
go -i sphere.nrrd -fr 0 0 6 -at 0 0 0 -up 0 1 0 -nc -1.2 -fc 1.2 -fov 20 -sz 150 150 -k bspln3 \
   -s 0.005 -us 0.01 -p rgbalit -b over -lut white-lut.nrrd -lev lev1.txt -lit white.txt -o "$out/levoy-g1.png"
go -i sphere10.nrrd -fr 0 0 6 -at 0 0 0 -up 0 1 0 -nc -1.2 -fc 1.2 -fov 20 -sz 150 150 -k bspln3 \
   -s 0.005 -us 0.01 -p rgbalit -b over -lut white-lut.nrrd -lev lev10.txt -lit white.txt -o "$out/levoy-g10.png"

# ---------------------------------------------------------------- 3. probes and blends
for p in v gm in; do
  for b in max sum mean; do
    go @cube-cam.txt -i cube.nrrd -sz 120 120 -k tent -s 0.05 -p $p -b $b -o "$out/pb-$p-$b.png"
  done
done
# Opacity correction: same -us, plane separation 0.04 vs 0.01.
for s in 0.04 0.01; do
  go @cube-cam.txt -i cube.nrrd -sz 150 150 -k bspln3 -s $s -us 0.02 -p rgbalit -b over \
     -lut cube-lut.nrrd -lit rgb.txt -o "$out/oc-s$s.png"
done

# ---------------------------------------------------------------- 4. lighting
printf '#space:=rgb\n1 1 1  1 0.5 1  0\n' > key.txt
"$R" lgen -i x <(printf '#space:=alpha\n-0.37 0\n-0.36 1\n') -mm -3 0 -l 4096 -o ball-lut.nrrd
for t in "amb 0.7 0 0 1" "dif 0 0.8 0 1" "spec 0 0 1 200" "all 0.2 0.6 0.4 60"; do
  set -- $t
  go -i ball.nrrd -fr 0 0 4 -at 0 0 0 -up 0 1 0 -nc -1 -fc 1 -fov 30 -sz 150 150 -ortho -k bspln3 \
     -s 0.004 -us 0.004 -p rgbalit -b over -lut ball-lut.nrrd -lit key.txt -ph $2 $3 $4 $5 -o "$out/bp-$1.png"
done
go @cube-cam.txt -i cube.nrrd -k ctmr -s 0.02 -us 0.02 -p rgbalit -b over -lut cube-lut.nrrd \
   -lit white.txt -dcn 1.2 1.1 0.9 -dcf 0.2 0.3 0.4 -o "$out/depth-cue.png"
go -i const.nrrd -fr 0 0 3 -at 0 0 0 -up 0 1 0 -nc -0.9 -fc 0.9 -fov 30 -sz 150 150 -k tent \
   -s 0.01 -us 1 -p rgbalit -b max -lut white-lut.nrrd -lit white.txt -ph 1 0 0 1 \
   -dcn 1 1 1 -dcf 0 0 0 -o "$out/depth-cue-const.png"

# ---------------------------------------------------------------- gallery (bundled data)
H="$top/data/itk-t1-head.nrrd"
HC="-at -127 -162.5 110 -fr 323 -12.5 260 -up 0 0 1 -nc -150 -fc 150 -fov 30"
for k in box tent bspln3; do
  for b in max mean sum; do
    go -i "$H" $HC -sz 120 120 -k $k -s 2 -p v -b $b -o "$out/grid-$k-$b.png"
  done
done
go -i "$H" $HC -sz 300 300 -k bspln3 -s 1 -p gm -b max -o "$out/head-gm-mip.png"

# ---------------------------------------------------------------- gallery (real CT, read from ../shared)
CT="$top/../shared/volumes/imageio-stent-ct.nrrd"
if [ -f "$CT" ]; then
  CC="-at 63.5 63.5 127.5 -up 0 0 -1 -nc -140 -fc 140 -sz 200 300 -k bspln3"
  go -i "$CT" $CC -fr 63.5 -536.5 127.5 -fov 26 -s 1 -p v -b max -o "$out/ct-mip.png"
  printf '#space:=rgb\n0 0.9 0.3 0.25\n600 0.95 0.6 0.5\n1500 1 1 1\n' > ctc.txt
  printf '#space:=alpha\n0 0\n200 0\n350 0.25\n800 0.6\n2000 1\n' > cta.txt
  "$R" lgen -i ctc.txt cta.txt -mm 0 2000 -o ct-lut.nrrd
  printf '#space:=rgb\n1 1 1  0 0 1  1\n' > front.txt
  go -i "$CT" $CC -fr 363.5 -436.5 227.5 -fov 30 -s 0.5 -us 1 -p rgbalit -b over \
     -lut ct-lut.nrrd -lit front.txt -ph 0.3 0.7 0.3 40 -o "$out/ct-over.png"
  # 2-D LUTs, next to teem-miter reading the same files (section 2): the CT's middle,
  # orthographic from -y, unlit (miter: ambient 1 only), every sample inside.
  if command -v teem-miter > /dev/null; then
    teem-unu dnorm -i "$CT" -o ct.nrrd
    printf 'arch 50 450 150 60  1 0.5 0.2 0.3\nbox 500 2000 30 2000  0.9 0.9 1 0.5\n' > vg.txt
    printf 'box 400 2000 -1 -0.02  0.2 0.4 1 0.6\nbox 400 2000 -0.02 0.02  1 1 1 0.6\nbox 400 2000 0.02 1  1 0.3 0.2 0.6\n' > vk.txt
    "$R" lgen2 -p vg.txt -q v gm -mm 0 2000 0 400 -l 200 100 -o vg.nrrd -oi "$out/lut2-v-gm.png"
    "$R" lgen2 -p vk.txt -q v k1 -mm 0 2000 -0.5 0.5 -l 200 100 -o vk.nrrd -oi "$out/lut2-v-k1.png"
    fov=$(awk 'BEGIN { print 2 * atan2(60, 400) * 180 / 3.14159265358979 }')
    for l in vg vk; do
      go -i ct.nrrd -fr 63.5 -336.5 127.5 -at 63.5 63.5 127.5 -up 0 0 1 -ortho -nc -60 -fc 60 \
         -fov "$fov" -sz 240 240 -k bspln3 -p rgba -b over -s 1 -us 1 -a1 0.99 -lut $l.nrrd \
         -o r.nrrd
      teem-miter -i ct.nrrd -txf $l.nrrd -fr 63.5 -336.5 127.5 -at 63.5 63.5 127.5 -up 0 0 1 \
         -rh -or -ar -dn -60 -di 0 -df 60 -ur -60 60 -vr -60 60 -is 240 240 -k00 bspln3 \
         -k11 bspln3d -k22 bspln3dd -step 1 -ref 1 -n1 0.99 -ads 1 0 0 -nt 2 -o m.nrrd 2> /dev/null
      teem-overrgb -i r.nrrd -b 0 0 0 -o "$out/lut2-$l-rendr.png"
      teem-unu crop -i m.nrrd -min 0 0 0 -max 3 M M | teem-unu convert -t float -o m4.nrrd
      teem-overrgb -i m4.nrrd -b 0 0 0 -o "$out/lut2-$l-miter.png"
    done
  fi
fi
