#!/usr/bin/env python3
"""Writes test volumes with independent writers (nibabel, SimpleITK) for rendr's
format tests (tests/tests/formats.rs).

Usage: write_volumes.py OUTDIR

For every case it writes the volume file(s), the values the writer itself reads back
(float64, little-endian, fastest axis first: NAME.f64) and one manifest line
(OUTDIR/manifest.txt, tab-separated):

    name  file  sizes(3)  expected-type  affine(12, rows of the 3x4 index-to-world)

The affine is the one the writer's own library reports for the file it wrote (nibabel's
img.affine, SimpleITK's direction * spacing and origin), so the test compares rendr
with the library, not with itself. expected-type is short, float or keep (the file's
own type, as rendr converts it).
"""
import os
import shutil
import sys

import numpy as np

OUT = sys.argv[1]
os.makedirs(OUT, exist_ok=True)
manifest = []

SIZES = (7, 6, 5)


def field(dtype, scale=1.0, offset=0.0):
    """A deterministic, non-symmetric test array (fastest axis first = Fortran order)."""
    i, j, k = np.meshgrid(*[np.arange(s) for s in SIZES], indexing="ij")
    v = (i * 7 + j * 13 + k * 29) % 97 - 40
    return np.asarray(v * scale + offset).astype(dtype)


def rot(ax, ay, az):
    cx, sx, cy, sy, cz, sz = (np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay),
                              np.cos(az), np.sin(az))
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def record(name, fname, values, kind, affine):
    values = np.asarray(values, dtype="<f8")
    assert values.shape == SIZES, (name, values.shape)
    values.ravel(order="F").tofile(os.path.join(OUT, name + ".f64"))
    a = np.asarray(affine, dtype=float)[:3, :4]
    manifest.append("\t".join([name, fname, " ".join(map(str, SIZES)), kind,
                               " ".join(repr(float(x)) for x in a.ravel())]))


def nifti_cases():
    import nibabel as nib

    def save(name, fname, img, kind):
        path = os.path.join(OUT, fname)
        nib.save(img, path)
        back = nib.load(path)
        record(name, fname, back.get_fdata(dtype=np.float64), kind, back.affine)

    obl = np.eye(4)
    obl[:3, :3] = rot(0.3, -0.2, 0.5) @ np.diag([0.9, 1.1, 1.7])
    obl[:3, 3] = [-12.5, 30.25, 7.0]

    # sform only, oblique, short.
    img = nib.Nifti1Image(field(np.int16), None)
    img.set_sform(obl, code=1)
    img.set_qform(None, code=0)
    save("nii-sform", "sform.nii", img, "short")

    # qform only, with a reflection (negative qfac), float, gzip.
    ref = obl.copy()
    ref[:3, 2] *= -1
    img = nib.Nifti1Image(field(np.float32, 0.5), None)
    img.set_qform(ref, code=1)
    img.set_sform(None, code=0)
    assert img.header["pixdim"][0] == -1, "qfac should be -1"
    save("nii-qform-qfac", "qform.nii.gz", img, "float")

    # Both: the sform (code 2) is used; uchar kept (converted to float by rendr).
    img = nib.Nifti1Image(field(np.uint8, 1.0, 40.0), None)
    img.set_qform(np.diag([2.0, 2.0, 2.0, 1.0]), code=1)
    img.set_sform(obl, code=2)
    save("nii-both", "both.nii", img, "keep")

    # NIfTI-2, double, big-endian header and data.
    hdr = nib.Nifti2Header(endianness=">")
    img = nib.Nifti2Image(field(np.float64, 0.25), obl, header=hdr)
    save("nii2", "two.nii", img, "keep")

    # Header/image pair, short.
    img = nib.Nifti1Pair(field(np.int16), obl)
    save("nii-pair", "pair.hdr", img, "short")

    # Rescale: integral (stays short) and fractional (becomes float).
    for name, slope, inter, kind in [("nii-scl-int", 1.0, -1024.0, "short"),
                                     ("nii-scl-frac", 0.5, 3.25, "float")]:
        img = nib.Nifti1Image(field(np.int16, 1.0, 100.0), obl)
        img.header.set_slope_inter(slope, inter)
        img.set_data_dtype(np.int16)
        # Keep the raw integers: write them through the array proxy's scaling.
        path = os.path.join(OUT, name + ".nii")
        hdr = img.header.copy()
        hdr.set_data_dtype(np.int16)
        hdr.set_slope_inter(slope, inter)
        raw = field(np.int16, 1.0, 100.0)
        with open(path, "wb") as f:
            hdr.set_data_offset(352)
            hdr.write_to(f)
            f.write(b"\0" * (352 - f.tell()))
            f.write(raw.astype(hdr.get_data_dtype()).tobytes(order="F"))
        back = nib.load(path)
        record(name, name + ".nii", back.get_fdata(dtype=np.float64), kind, back.affine)

    # Axis-aligned, binary-fraction spacings: exact in every format (render test).
    al = np.diag([0.5, 0.25, 2.0, 1.0])
    al[:3, 3] = [-8.0, -4.0, 2.0]
    img = nib.Nifti1Image(field(np.int16), al)
    save("nii-aligned", "aligned.nii.gz", img, "short")


def metaimage_cases():
    import SimpleITK as sitk

    def image(arr, spacing, origin, direction):
        # SimpleITK arrays are (k, j, i).
        im = sitk.GetImageFromArray(np.transpose(arr, (2, 1, 0)).copy())
        im.SetSpacing(spacing)
        im.SetOrigin(origin)
        im.SetDirection(direction)
        return im

    def save(name, fname, im, kind, compress=False):
        path = os.path.join(OUT, fname)
        sitk.WriteImage(im, path, compress)
        back = sitk.ReadImage(path)
        vals = np.transpose(sitk.GetArrayFromImage(back), (2, 1, 0)).astype(np.float64)
        d = np.array(back.GetDirection()).reshape(3, 3)
        a = np.zeros((3, 4))
        a[:, :3] = d @ np.diag(back.GetSpacing())
        a[:, 3] = back.GetOrigin()
        record(name, fname, vals, kind, a)

    r = rot(-0.4, 0.25, 0.1)
    direction = tuple(r.ravel())
    save("mha-oblique", "oblique.mha",
         image(field(np.int16), (0.7, 0.8, 1.5), (10.0, -20.5, 3.0), direction), "short")
    save("mhd-float", "float.mhd",
         image(field(np.float32, 0.5), (1.25, 1.0, 0.5), (-1.0, 2.0, -3.0), direction),
         "float")
    save("mha-zlib", "zlib.mha",
         image(field(np.uint16, 1.0, 50.0), (0.5, 0.5, 2.0), (0.0, 0.0, 0.0), direction),
         "keep", compress=True)
    save("mhd-zlib", "zlib.mhd",
         image(field(np.float64, 0.125), (1.0, 2.0, 3.0), (4.0, 5.0, 6.0), direction),
         "keep", compress=True)
    save("mha-aligned", "aligned.mha",
         image(field(np.int16), (0.5, 0.25, 2.0), (-8.0, -4.0, 2.0),
               (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)), "short")


def ds_str(x):
    """A number as DICOM writes it: a decimal string of at most 16 characters."""
    for digits in range(12, 5, -1):
        t = f"{x:.{digits}g}"
        if len(t) <= 16:
            return t
    raise ValueError(x)


def dicom_cases():
    import random
    import pydicom
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.sequence import Sequence
    from pydicom.uid import (ExplicitVRLittleEndian, ImplicitVRLittleEndian, RLELossless,
                             DeflatedExplicitVRLittleEndian, generate_uid, CTImageStorage,
                             EnhancedCTImageStorage)

    rng = random.Random(1234)

    def base(series_uid, ts, sop_class):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = sop_class
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ts
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID = sop_class
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID = generate_uid()
        ds.SeriesInstanceUID = series_uid
        ds.Modality = "CT"
        ds.PatientName = "Test^Rendr"
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        return ds

    def pixel_attrs(ds, raw):
        ds.Rows, ds.Columns = raw.shape
        bits = raw.dtype.itemsize * 8
        ds.BitsAllocated = bits
        ds.BitsStored = bits
        ds.HighBit = bits - 1
        ds.PixelRepresentation = 1 if raw.dtype.kind == "i" else 0

    def series(name, raw, spacing, origin, r, c, step, slope, inter, ts, kind,
               shuffle=True, drop=None, extra=None):
        """Slices k of raw (fastest axis first: i, j, k) at origin + k * step."""
        d = os.path.join(OUT, name)
        os.makedirs(d, exist_ok=True)
        uid = generate_uid()
        k_all = list(range(raw.shape[2]))
        order = k_all[:]
        if shuffle:
            rng.shuffle(order)
        for n_inst, k in enumerate(order):
            if drop is not None and k == drop:
                continue
            ds = base(uid, ts, CTImageStorage)
            ds.InstanceNumber = len(order) - n_inst
            pos = [origin[i] + k * step[i] for i in range(3)]
            ds.ImagePositionPatient = [ds_str(x) for x in pos]
            ds.ImageOrientationPatient = [ds_str(x) for x in list(r) + list(c)]
            ds.PixelSpacing = [ds_str(spacing[0]), ds_str(spacing[1])]
            ds.SliceThickness = ds_str(float(np.linalg.norm(step)))
            ds.RescaleSlope = ds_str(slope)
            ds.RescaleIntercept = ds_str(inter)
            plane = np.ascontiguousarray(raw[:, :, k].T)  # rows = j, columns = i
            pixel_attrs(ds, plane)
            if ts == RLELossless:
                ds.file_meta.TransferSyntaxUID = ExplicitVRLittleEndian
                ds.PixelData = plane.tobytes()
                ds.compress(RLELossless, plane)
            else:
                ds.PixelData = plane.tobytes()
            if extra:
                extra(ds, k)
            fname = "%08x" % rng.getrandbits(32)  # names say nothing about order
            ds.save_as(os.path.join(d, fname), enforce_file_format=True,
                       implicit_vr=(ts == ImplicitVRLittleEndian), little_endian=True)
        a = np.zeros((3, 4))
        a[:, 0] = np.asarray(r) * spacing[1]
        a[:, 1] = np.asarray(c) * spacing[0]
        a[:, 2] = step
        a[:, 3] = origin
        if kind is not None:
            record(name, name, raw.astype(np.float64) * slope + inter, kind, a)
        return d

    r0 = rot(0.35, -0.15, 0.6)
    r, c = r0[:, 0], r0[:, 1]
    normal = np.cross(r, c)
    # Oblique, no tilt, short stored values with an intercept; shuffled names.
    series("dcm-oblique", field(np.int16, 1.0, 100.0), (0.75, 0.625), (-30.5, 12.25, 80.0),
           r, c, normal * 1.25, 1.0, -1024.0, ExplicitVRLittleEndian, "short")
    # Unsigned, fractional rescale -> float; implicit VR.
    series("dcm-frac", field(np.uint16, 1.0, 60.0), (0.5, 0.5), (1.0, 2.0, 3.0),
           r, c, normal * 2.0, 0.5, -7.25, ImplicitVRLittleEndian, "float")
    # RLE Lossless (decoded by dicom-pixeldata).
    series("dcm-rle", field(np.int16, 1.0, 0.0), (1.0, 1.0), (0.0, 0.0, 0.0),
           r, c, normal * 1.5, 1.0, 0.0, RLELossless, "short")
    # Deflated explicit VR little endian: the whole data set one deflate stream.
    series("dcm-deflated", field(np.int16, 1.0, 0.0), (0.75, 0.75), (2.0, -3.0, 5.0),
           r, c, normal * 1.0, 1.0, 0.0, DeflatedExplicitVRLittleEndian, "short")
    # Axis-aligned, binary fractions: renders like the NRRD (LPS).
    series("dcm-aligned", field(np.int16), (0.25, 0.5), (-8.0, -4.0, 2.0),
           (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), np.array([0.0, 0.0, 2.0]), 1.0, 0.0,
           ExplicitVRLittleEndian, "short")

    # Enhanced multi-frame: per-frame positions, shared orientation and spacing.
    raw = field(np.int16, 1.0, 5.0)
    step = normal * 1.75
    origin = (4.0, -5.0, 6.0)
    uid = generate_uid()
    ds = base(uid, ExplicitVRLittleEndian, EnhancedCTImageStorage)
    ds.NumberOfFrames = raw.shape[2]
    shared = Dataset()
    po = Dataset()
    po.ImageOrientationPatient = [ds_str(x) for x in list(r) + list(c)]
    pm = Dataset()
    pm.PixelSpacing = [ds_str(0.8), ds_str(0.9)]
    pm.SliceThickness = ds_str(1.75)
    pv = Dataset()
    pv.RescaleSlope = "1"
    pv.RescaleIntercept = "-100"
    pv.RescaleType = "HU"
    shared.PlaneOrientationSequence = Sequence([po])
    shared.PixelMeasuresSequence = Sequence([pm])
    shared.PixelValueTransformationSequence = Sequence([pv])
    ds.SharedFunctionalGroupsSequence = Sequence([shared])
    frames = []
    order = list(range(raw.shape[2]))
    rng.shuffle(order)  # frames stored out of spatial order
    for k in order:
        f = Dataset()
        pp = Dataset()
        pp.ImagePositionPatient = [ds_str(origin[i] + k * step[i]) for i in range(3)]
        f.PlanePositionSequence = Sequence([pp])
        frames.append(f)
    ds.PerFrameFunctionalGroupsSequence = Sequence(frames)
    planes = [np.ascontiguousarray(raw[:, :, k].T) for k in order]
    pixel_attrs(ds, planes[0])
    ds.PixelData = b"".join(p.tobytes() for p in planes)
    os.makedirs(os.path.join(OUT, "dcm-multiframe"), exist_ok=True)
    ds.save_as(os.path.join(OUT, "dcm-multiframe", "enhanced.dcm"), enforce_file_format=True)
    a = np.zeros((3, 4))
    a[:, 0] = r * 0.9
    a[:, 1] = c * 0.8
    a[:, 2] = step
    a[:, 3] = origin
    record("dcm-multiframe", "dcm-multiframe/enhanced.dcm", raw.astype(np.float64) - 100.0,
           "short", a)

    # Bad series (not in the manifest): two series in one folder, a missing slice, an
    # unsupported transfer syntax.
    bad = os.path.join(OUT, "bad")
    os.makedirs(bad, exist_ok=True)
    for sub in ("two-series",):
        d = series(os.path.join("bad", sub), field(np.int16), (1.0, 1.0), (0, 0, 0), r, c,
                   normal, 1.0, 0.0, ExplicitVRLittleEndian, None)
        d2 = series(os.path.join("bad", sub + "-b"), field(np.int16), (1.0, 1.0), (0, 0, 0),
                    r, c, normal, 1.0, 0.0, ExplicitVRLittleEndian, None)
        for f in os.listdir(d2):
            os.replace(os.path.join(d2, f), os.path.join(d, "b" + f))
        os.rmdir(d2)
    series(os.path.join("bad", "missing-slice"), field(np.int16), (1.0, 1.0), (0, 0, 0), r, c,
           normal, 1.0, 0.0, ExplicitVRLittleEndian, None, drop=2)

    def j2k(ds, k):
        ds.file_meta.TransferSyntaxUID = "1.2.840.10008.1.2.4.90"  # JPEG 2000 lossless
        from pydicom.encaps import encapsulate
        ds.PixelData = encapsulate([b"\xff\x4f\xff\x51" + bytes(64)])
    series(os.path.join("bad", "jpeg2000"), field(np.int16), (1.0, 1.0), (0, 0, 0), r, c,
           normal, 1.0, 0.0, ExplicitVRLittleEndian, None, extra=j2k)

    # A series beside objects that are no images of it (as exports hold): a report
    # without pixels, in the series and in a series of its own, and a slice of another
    # series that can't be decoded (JPEG 2000). Named by one of its files, the series
    # reads; the folder holds two series of images (the reports are none).
    d = series(os.path.join("bad", "with-others"), field(np.int16), (1.0, 1.0), (0, 0, 0),
               r, c, normal, 1.0, 0.0, ExplicitVRLittleEndian, None)
    own = pydicom.dcmread(os.path.join(d, sorted(os.listdir(d))[0])).SeriesInstanceUID
    for name, uid in (("report-own", generate_uid()), ("report-in", own)):
        sr = base(uid, ExplicitVRLittleEndian, "1.2.840.10008.5.1.4.1.1.88.11")
        sr.Modality = "SR"
        sr.save_as(os.path.join(d, name), enforce_file_format=True,
                   implicit_vr=False, little_endian=True)
    j = os.path.join(OUT, "bad", "jpeg2000")
    shutil.copy(os.path.join(j, sorted(os.listdir(j))[0]), os.path.join(d, "other-j2k"))


nifti_cases()
metaimage_cases()
dicom_cases()
with open(os.path.join(OUT, "manifest.txt"), "w") as f:
    f.write("\n".join(manifest) + "\n")
print(f"wrote {len(manifest)} cases to {OUT}")
