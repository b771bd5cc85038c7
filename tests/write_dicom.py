#!/usr/bin/env python3
"""write_dicom.py — write a volume as a DICOM CT series with pydicom (code
independent of ohm and of GDCM), for tests/test_scan_formats.c and for the
bundled sample (scripts/make-walnut-dicom.sh).

The volume is a headerless raw file (x fastest) with its index-to-world map
in RAS millimetres (NIfTI's convention, ohm's world); the series gets that
geometry in DICOM's LPS patient coordinates (PS3.3 C.7.6.2.1.1): x columns
along the row direction, y rows along the column direction, one file per z
slice at ImagePositionPatient = origin + k * (slice axis).  Stored values
are (value - intercept) / slope, which must come out whole.

--case makes the broken series the reader must refuse: missing (a middle
slice left out), duplicate (a slice at its neighbour's position), tilted
(one slice with another orientation), truncated (a file cut short in its
pixel data).  --rle compresses the pixels (RLE Lossless, encapsulated).  --dicomdir writes a DICOM File-set (a DICOMDIR and the
PS3.10 folder layout) through pydicom.fileset instead of a plain folder.
File names are scrambled by default (--names shuffled): the reader must
sort by position, never by name or InstanceNumber."""

import argparse
import os
import sys

import numpy as np
import pydicom
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

CT_IMAGE_STORAGE = "1.2.840.10008.5.1.4.1.1.2"


def ds_string(x):
    """A decimal string (DS) of at most 16 characters (PS3.5 6.2), as exact as fits."""
    for digits in range(17, 0, -1):
        s = "%.*g" % (digits, x)
        if len(s) <= 16:
            return s
    raise ValueError(x)


def geometry(matrix):
    """IOP, PixelSpacing, the slice step and origin in LPS from a RAS map."""
    m = np.array(matrix, dtype=float).reshape(3, 4)
    lps = np.diag([-1.0, -1.0, 1.0]) @ m
    cols = [lps[:, a] for a in range(3)]
    spacing = [float(np.linalg.norm(c)) for c in cols]
    row_dir, col_dir = cols[0] / spacing[0], cols[1] / spacing[1]
    return list(row_dir) + list(col_dir), [spacing[1], spacing[0]], cols[2], lps[:, 3]


def uid(args, *what):
    return generate_uid(entropy_srcs=[args.uid_seed] + [str(w) for w in what]) if args.uid_seed else generate_uid()


def slice_dataset(args, k, pixels, iop, pixel_spacing, position, study, series, instance):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = CT_IMAGE_STORAGE
    meta.MediaStorageSOPInstanceUID = uid(args, "slice", k)
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta = meta
    ds.is_little_endian, ds.is_implicit_VR = True, False
    ds.SOPClassUID, ds.SOPInstanceUID = CT_IMAGE_STORAGE, meta.MediaStorageSOPInstanceUID
    ds.StudyInstanceUID, ds.SeriesInstanceUID = study, series
    ds.Modality, ds.PatientName, ds.PatientID = "CT", args.patient, args.patient.replace("^", "-")
    ds.StudyDate, ds.StudyTime, ds.StudyID, ds.AccessionNumber = "20261203", "120000", "1", ""
    ds.SeriesNumber, ds.InstanceNumber = 1, instance
    ds.SeriesDescription = args.description
    ds.ImageOrientationPatient = [ds_string(v) for v in iop]
    ds.ImagePositionPatient = [ds_string(v) for v in position]
    ds.PixelSpacing = [ds_string(v) for v in pixel_spacing]
    ds.SliceThickness = ds_string(args.thickness)
    ds.Rows, ds.Columns = pixels.shape
    ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
    ds.BitsAllocated = ds.BitsStored = 16
    ds.HighBit = 15
    ds.PixelRepresentation = 1 if args.stored == "i16" else 0
    ds.RescaleSlope, ds.RescaleIntercept = ds_string(args.slope), ds_string(args.intercept)
    ds.RescaleType = args.rescale_type
    ds.PixelData = pixels.astype("<i2" if args.stored == "i16" else "<u2").tobytes()
    return ds


def stored_values(args, dims):
    raw = np.fromfile(args.raw, dtype={"i16": "<i2", "u16": "<u2", "f32": "<f4"}[args.type]).astype(np.float64)
    if raw.size != dims[0] * dims[1] * dims[2]:
        sys.exit("%s: %d values, expected %d" % (args.raw, raw.size, dims[0] * dims[1] * dims[2]))
    stored = (raw - args.intercept) / args.slope
    lo, hi = (-32768, 32767) if args.stored == "i16" else (0, 65535)
    if np.any(stored != np.round(stored)) or stored.min() < lo or stored.max() > hi:
        sys.exit("%s: the values are not whole %s numbers after the rescale" % (args.raw, args.stored))
    return stored.reshape(dims[2], dims[1], dims[0])  # slice, row, column


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="folder to write into (created)")
    p.add_argument("--raw", required=True)
    p.add_argument("--type", choices=["i16", "u16", "f32"], default="i16", help="the raw file's voxels")
    p.add_argument("--dims", required=True, help="nx,ny,nz")
    p.add_argument("--matrix", required=True, help="12 numbers: the RAS index-to-world map, row by row")
    p.add_argument("--slope", type=float, default=1.0)
    p.add_argument("--intercept", type=float, default=0.0)
    p.add_argument("--stored", choices=["i16", "u16"], default="u16")
    p.add_argument("--rescale-type", default="HU", help="RescaleType (0028,1054): HU, or US (unspecified)")
    p.add_argument("--thickness", type=float, default=1.0)
    p.add_argument("--series-uid", default=None)
    p.add_argument("--uid-seed", default=None,
                   help="derive every UID from this text (pydicom's root), for a reproducible series")
    p.add_argument("--description", default="ohm test series")
    p.add_argument("--patient", default="ohm^test", help="PatientName (PatientID: the same)")
    p.add_argument("--prefix", default="IM", help="file names: PREFIX<number>.dcm")
    p.add_argument("--names", choices=["shuffled", "ordered"], default="shuffled")
    p.add_argument("--case", choices=["ok", "missing", "duplicate", "tilted", "truncated"], default="ok")
    p.add_argument("--dicomdir", action="store_true")
    p.add_argument("--rle", action="store_true", help="RLE Lossless (an encapsulated transfer syntax: GDCM decodes it)")
    args = p.parse_args()

    dims = [int(v) for v in args.dims.split(",")]
    matrix = [float(v) for v in args.matrix.split(",")]
    stored = stored_values(args, dims)
    iop, pixel_spacing, step, origin = geometry(matrix)
    study, series = uid(args, "study"), args.series_uid or uid(args, "series")
    nz = dims[2]
    # file number and InstanceNumber of slice k: a fixed scramble, so that
    # neither the names nor the instance numbers give the order
    order = list(range(nz)) if args.names == "ordered" else [(k * 5 + 3) % nz if nz % 5 else nz - 1 - k
                                                             for k in range(nz)]
    datasets = []
    for k in range(nz):
        if args.case == "missing" and k == nz // 2:
            continue
        at = k - 1 if args.case == "duplicate" and k == nz // 2 else k
        turned = list(iop)
        if args.case == "tilted" and k == nz // 2:
            turned = turned[3:] + turned[:3]
        ds = slice_dataset(args, k, stored[k], turned, pixel_spacing, origin + at * step, study, series,
                           order[k] + 1)
        if args.rle:
            from pydicom.uid import RLELossless
            ds.compress(RLELossless, stored[k].astype("<i2" if args.stored == "i16" else "<u2"))
        datasets.append((order[k], ds))
    os.makedirs(args.out, exist_ok=True)
    if args.dicomdir:
        from pydicom.fileset import FileSet
        fs = FileSet()
        for _, ds in datasets:
            fs.add(ds)
        fs.write(args.out)
        return
    for number, ds in datasets:
        path = os.path.join(args.out, "%s%04d.dcm" % (args.prefix, number + 1))
        ds.save_as(path, write_like_original=False)
        if args.case == "truncated" and number == order[nz // 2]:
            os.truncate(path, os.path.getsize(path) - 7)


if __name__ == "__main__":
    main()
