#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets (tests/fuzz/corpus/<target>/): tiny valid volumes, a few bytes each.

The files are checked in; rerun this script only to change them:  python3 tests/fuzz/make_corpus.py
"""
import gzip
import os
import shutil
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")


def write(target, name, data):
    d = os.path.join(CORPUS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def gz(data):
    return gzip.compress(data, mtime=0)


LABELS8 = bytes([0, 1, 1, 2, 0, 3, 2, 1])  # 2x2x2

# NRRD -----------------------------------------------------------------------------------------------------------------
nrrd = {
    "u8_raw.nrrd": b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                   b"spacings: 1 1 2\n\n" + LABELS8,
    "u16_gzip_dirs.nrrd": b"NRRD0005\n# comment\ntype: unsigned short\ndimension: 3\nspace dimension: 3\n"
                          b"sizes: 2 2 2\nspace directions: (0,0.5,0) (-1,0,0) (0,0,2)\nkinds: domain domain domain\n"
                          b"endian: big\nencoding: gzip\nspace origin: (1,2,3)\nkey:=value\n\n"
                          + gz(struct.pack(">8H", *LABELS8)),
    "i16_2d_byteskip.nrrd": b"NRRD0004\r\ntype: short\r\ndimension: 2\r\nsizes: 2 3\r\nendian: little\r\n"
                            b"encoding: raw\r\nbyte skip: -1\r\nline skip: 0\r\n\r\n"
                            + b"junk" + struct.pack("<6h", 0, 1, 2, 3, 4, 5),
    "detached.nhdr": b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: input.raw\n",
}
for name, data in nrrd.items():
    write("nrrd", name, data)

# MetaImage ------------------------------------------------------------------------------------------------------------
mha = {
    "u8_local.mha": b"ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementSpacing = 1 1 1\n"
                    b"ElementType = MET_UCHAR\nElementDataFile = LOCAL\n" + LABELS8,
    "u16_zlib_msb.mha": b"ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = True\n"
                        b"CompressedData = True\nTransformMatrix = 0 1 0 -1 0 0 0 0 1\nOffset = 1 2 3\n"
                        b"ElementSpacing = 0.5 1 2\nDimSize = 2 2 2\nElementType = MET_USHORT\n"
                        b"ElementDataFile = LOCAL\n" + zlib.compress(struct.pack(">8H", *LABELS8)),
    "i32_2d_headersize.mha": b"NDims = 2\nDimSize = 3 2\nElementSize = 1 1\nElementNumberOfChannels = 1\n"
                             b"ElementType = MET_INT\nHeaderSize = -1\nElementDataFile = LOCAL\n"
                             + struct.pack("<6i", 0, 1, 2, 3, 4, 5),
    "detached.mhd": b"ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_CHAR\n"
                    b"ElementDataFile = input.raw\n",
}
for name, data in mha.items():
    write("metaimage", name, data)


# NIfTI-1 --------------------------------------------------------------------------------------------------------------
def nifti(endian, datatype, fmt, samples, sform, qform):
    h = bytearray(352)
    struct.pack_into(endian + "i", h, 0, 348)
    struct.pack_into(endian + "8h", h, 40, 3, 2, 2, 2, 1, 1, 1, 1)
    struct.pack_into(endian + "h", h, 70, datatype)
    struct.pack_into(endian + "8f", h, 76, -1 if qform else 1, 1, 1.5, 2, 1, 1, 1, 1)
    struct.pack_into(endian + "f", h, 108, 352)  # vox_offset
    struct.pack_into(endian + "f", h, 112, 1)  # scl_slope
    struct.pack_into(endian + "2h", h, 252, qform, sform)
    if qform:
        struct.pack_into(endian + "6f", h, 256, 0, 0, 1, 10, 20, 30)  # 180 degrees about z, offsets
    if sform:
        struct.pack_into(endian + "12f", h, 280, 0, -1, 0, 5, 2, 0, 0, 6, 0, 0, 1, 7)
    h[344:348] = b"n+1\0"
    return bytes(h) + struct.pack(endian + str(len(samples)) + fmt, *samples)


nii = {
    "u8_sform_le.nii": nifti("<", 2, "B", LABELS8, 1, 0),
    "i16_qform_be.nii": nifti(">", 4, "h", LABELS8, 0, 1),
    "u16_pixdim_le.nii": nifti("<", 512, "H", LABELS8, 0, 0),
}
for name, data in nii.items():
    write("nifti", name, data)


# INRIMAGE-4 -----------------------------------------------------------------------------------------------------------
def inr(fields, samples):
    header = b"#INRIMAGE-4#{\n" + fields
    total = (len(header) + 4 + 255) // 256 * 256
    return header + b"\n" * (total - len(header) - 4) + b"##}\n" + samples


inrs = {
    "u8.inr": inr(b"XDIM=2\nYDIM=2\nZDIM=2\nVDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\nSCALE=2**0\nCPU=decm\n"
                  b"VX=1\nVY=1\nVZ=2\nTX=1\nTY=2\nTZ=3\n", LABELS8),
    "i16_sun.inr": inr(b"XDIM=2\nYDIM=2\nZDIM=2\nTYPE=signed fixed\nPIXSIZE=16 bits\nCPU=sun\n# comment\n",
                       struct.pack(">8h", *LABELS8)),
}
for name, data in inrs.items():
    write("inrimage", name, data)

# read_volume: every format, and whole-file gzip of each single-file one; a headerless raw file. --------------------
for group in (nrrd, mha, nii, inrs):
    for name, data in group.items():
        write("read_volume", name, data)
write("read_volume", "u8_sform_le.nii.gz", gz(nii["u8_sform_le.nii"]))
write("read_volume", "i16_sun.inr.gz", gz(inrs["i16_sun.inr"]))
write("read_volume", "u8_raw.nrrd.gz", gz(nrrd["u8_raw.nrrd"]))
write("read_volume", "headerless.raw", bytes([0x15]) + bytes(15))
