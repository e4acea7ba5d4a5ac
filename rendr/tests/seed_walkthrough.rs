//! The seed's whole walkthrough (../shared/seed/p3rendr-2017.txt) as one test: every
//! command it shows, with `rendr` for `./rrendr` and Teem's `teem-unu` / `teem-overrgb`
//! for `unu` / `overrgb`, run through bash in a scratch directory; each must succeed and
//! produce its files. Needs Teem and ../shared (skipped otherwise, unless required).

use std::process::Command;

#[test]
fn seed_walkthrough_runs() {
    let Some(sh) = rnd_tests::shared("seed_walkthrough_runs") else {
        return;
    };
    if !rnd_tests::teem("seed_walkthrough_runs", "teem-unu") {
        return;
    }
    let d = rnd_tests::tmpdir("seed");
    let bin = d.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    // ./rrendr -> rendr; unu -> teem-unu; overrgb -> teem-overrgb.
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_rendr"), d.join("rrendr")).unwrap();
    std::os::unix::fs::symlink("/usr/bin/teem-unu", bin.join("unu")).unwrap();
    std::os::unix::fs::symlink("/usr/bin/teem-overrgb", bin.join("overrgb")).unwrap();
    // $SCIVIS layout: the seed's cmap/ and lit/ files from rendr-data; drawlut.sh made
    // with rendr lgen -oi's picture.
    let scivis = d.join("scivis");
    for sub in ["cmap", "lit", "data/3d"] {
        std::fs::create_dir_all(scivis.join(sub)).unwrap();
    }
    let rd = sh.join("rendr-data");
    std::fs::copy(
        rd.join("cube-atxf1.txt"),
        scivis.join("cmap/cube-atxf1.txt"),
    )
    .unwrap();
    std::fs::copy(rd.join("rgb.txt"), scivis.join("lit/rgb.txt")).unwrap();
    std::fs::copy(rd.join("1.txt"), scivis.join("lit/1.txt")).unwrap();
    // drawlut.sh: the course's script is not public; this stand-in makes a small grey
    // picture of a LUT with unu (`rendr lgen -oi` is rendr's own LUT picture).
    std::fs::write(
        d.join("drawlut.sh"),
        "#!/bin/bash\nset -e\nunu resample -i \"$1\" -s = 300 -k box | unu axinsert -a 2 -s 40 \
         | unu 2op x - 1 | unu project -a 0 -m max | unu quantize -b 8 -o \"$2\"\n",
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(d.join("drawlut.sh"), std::fs::Permissions::from_mode(0o755)).unwrap();
    let script = r##"
set -euo pipefail
export PATH="$PWD/bin:$PATH"
SCIVIS="$PWD/scivis"
echo 0 | unu pad -min 0 0 -max 3 2 | unu 1op nrand -o mat.txt
echo 0 0 0 1 >> mat.txt
./rrendr 4mi mat.txt
echo -e "#range:=alpha\n0 0\n1 1" > atxf.txt
echo -e "#range:=rgb\n0 0 1 0\n1 1 0 1" > ctxf.txt
./rrendr lgen -i ctxf.txt atxf.txt -mm 0 1 -rs false false -o lut-0.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs true true -o lut-1.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs false true -o lut-2.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs true false -o lut-3.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs false false -o lut-4.nrrd
rm -f lut-?.png
for I in 0 1 2 3 4; do ./drawlut.sh lut-$I.nrrd lut-$I.png; done
echo -e "#range:=alpha\n0 0\n1 1" > atxf.txt
echo -e "#range:=hsv\n0 0 1 1\n0.33 0.33 1 1\n0.66 0.66 1 1\n1 1 1 1" > ctxf.txt
./rrendr lgen -i ctxf.txt atxf.txt -mm 0 1 -rs false false -o lut-0.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs true true -o lut-1.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs false true -o lut-2.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs true false -o lut-3.nrrd
./rrendr lgen -i ctxf.txt atxf.txt -mm -2 3 -rs false false -o lut-4.nrrd
for I in 0 1 2 3 4; do ./drawlut.sh lut-$I.nrrd lut-$I.png; done
echo -e "0.3 1 0.5\n0.7 0.3 1.3" | ./rrendr levoy -i - -mm 0 1 -gm 1 -o lev.nrrd
unu quantize -b 8 -i lev.nrrd -min 0 -max 1 -o lev.png
./rrendr sdg -w 0 -l 5 5 5 -sz 25 25 25 -o zramp0.nrrd
./rrendr sdg -w 0 -l 5 5 5 -sz 25 25 25 -o zramp0-us.nrrd -t short -vs 4 10000
./rrendr sdg -w 0 -l 5 5 5 -sz 20 25 30 -o zramp1.nrrd
./rrendr sdg -w 0 -l 5 5 5 -sz 20 25 30 -r 0.5 0.6 -0.3 -o zramp2.nrrd
./rrendr sdg -w 0 -l 5 5 5 -sz 20 25 30 -r 0.5 0.6 -0.3 -sh 0.1 -0.2 0.3 -c 0.1 -0.1 0.3 -o zramp3.nrrd
./rrendr sdg -w 0 -l 5 5 5 -sz 20 25 30 -r 0.5 0.6 -0.3 -sh 0.1 -0.2 0.3 -c 0.1 -0.1 0.3 -o zramp3-us.nrrd -t short -vs 4 10000
for K in tent bspln2 bspln3 c4hexic; do for X in 0 1 2 3; do
  echo "========== zramp${X}.nrrd with $K"
  ./rrendr ceval -i zramp${X}.nrrd -k $K -w 0.2 0.4 0.8 -g true
done; done
for K in tent bspln2 bspln3 c4hexic; do for X in 0 3; do
  echo "========== zramp${X}-us.nrrd with $K"
  ./rrendr ceval -i zramp${X}-us.nrrd -k $K -w 0.2 0.4 0.8 -g true
done; done
./rrendr sdg -w 2 -l 4 4 4 -o cube.nrrd
echo "-fr 6 12 5 -at 0 0 0" > cube-cam.txt
echo "-up 0 0 1" >> cube-cam.txt
echo "-nc -2.56304 -fc 2.56304 -fov 16" >> cube-cam.txt
echo "-sz 300 300" >> cube-cam.txt
CUBE="@cube-cam.txt -i cube.nrrd"
./rrendr go $CUBE -s 0 -k box -p pv -b sum -o pv.nrrd
unu slice -i pv.nrrd -a 1 2 -p 0 0 | unu save -f text
unu slice -i pv.nrrd -a 1 2 -p M 0 | unu save -f text
unu slice -i pv.nrrd -a 1 2 -p 0 M | unu save -f text
unu slice -i pv.nrrd -a 1 2 -p M M | unu save -f text
./rrendr cam @cube-cam.txt
unu slice -i pv.nrrd -a 0 -p 2 | unu minmax -
./rrendr go $CUBE -s 0 -k box -p pw -b sum -o pw.nrrd
unu slice -i pw.nrrd -a 1 2 -p 0 0 | unu save -f text
unu slice -i pw.nrrd -a 1 2 -p M M | unu save -f text
./rrendr go $CUBE -s 0 -k box -p pi -b sum -o pi.nrrd
for K in box tent bspln3; do ./rrendr go $CUBE -s 0 -k $K -p v -b sum -o v-$K.nrrd; done
unu join -i v-{box,tent,bspln3}.nrrd -a 1 | unu quantize -b 8 -o v-test.png
for K in box tent bspln3; do ./rrendr go $CUBE -s 0 -k $K -p in -b sum -o in-$K.nrrd; done
unu join -i in-{box,tent,bspln3}.nrrd -a 1 | unu quantize -b 8 -o in-test.png
for P in v gv gm; do
  ./rrendr go $CUBE -nc -1 -s 0 -k tent -p $P -b sum -o $P-1.nrrd
  unu quantize -b 8 -i $P-1.nrrd -o $P-1.png
done
./rrendr go $CUBE -s 0 -nc -2 -fc 3 -k box -p pv -b sum -o pv0.nrrd
./rrendr go $CUBE -s 1 -nc -2 -fc -1.5 -k box -p pv -b sum -o pv1.nrrd
./rrendr go $CUBE -s 1 -nc -2 -fc -0.5 -k box -p pv -b sum -o pv2.nrrd
unu diff pv0.nrrd pv1.nrrd || true
unu 2op x pv1.nrrd 2 | unu 2op - pv2.nrrd - -o step.nrrd
unu slice -i step.nrrd -a 1 2 -p 0 0 | unu save -f text
./rrendr go $CUBE -s 1 -nc -2 -fc -1.5 -k box -p pv -b sum -ortho -o pv1o.nrrd
./rrendr go $CUBE -s 1 -nc -2 -fc -0.5 -k box -p pv -b sum -ortho -o pv2o.nrrd
unu 2op x pv1o.nrrd 2 | unu 2op - pv2o.nrrd - -o stepo.nrrd
unu slice -i stepo.nrrd -a 1 2 -p M M | unu save -f text
for B in max sum mean; do
  ./rrendr go $CUBE -s 0.1 -k box -p v -b $B -o p-$B.nrrd
  unu quantize -b 8 -i p-$B.nrrd -o p-$B.png
done
./rrendr lgen -i x $SCIVIS/cmap/cube-atxf1.txt -mm 0 1 -o lut.nrrd
./rrendr go $CUBE -us 0.03 -s 0.03 -k ctmr -p rgbalit -b over -lut lut.nrrd -lit $SCIVIS/lit/rgb.txt -o cube-rgb.nrrd
overrgb -i cube-rgb.nrrd -b 0 0 0 -o cube-rgb.png
./rrendr go $CUBE -us 0.03 -s 0.03 -k ctmr -p rgbalit -b over -lut lut.nrrd -lit $SCIVIS/lit/1.txt -dcn 1.2 1.1 0.9 -dcf 0.2 0.3 0.4 -o cube-dc.nrrd
overrgb -i cube-dc.nrrd -b 0 0 0 -o cube-dc.png
./rrendr go $CUBE -s 0.1 -k tent -p v -b max -t -o out.nrrd
unu slice -i out.nrrd -a 0 -p M | unu quantize -b 8 -o time.png
"##;
    let out = Command::new("bash")
        .arg("-c")
        .arg(script)
        .current_dir(&d)
        .output()
        .unwrap();
    let so = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "seed walkthrough failed:\n{}\n{}",
        so,
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "mat.txt",
        "lut-4.png",
        "lev.png",
        "zramp3-us.nrrd",
        "pv.nrrd",
        "v-test.png",
        "in-test.png",
        "gm-1.png",
        "step.nrrd",
        "stepo.nrrd",
        "p-mean.png",
        "cube-rgb.png",
        "cube-dc.png",
        "time.png",
    ] {
        assert!(d.join(f).exists(), "{f} was not made");
    }
    // What the seed says about some of the printed output.
    assert!(so.contains("11.7548 = ncv"));
    assert!(so.contains("max: -11.75478"), "{so}");
    assert_eq!(so.matches("=rndConvoEval").count(), 16 + 8);
    assert!(so.contains("= FrobeniusNorm(P-I)"));
}
