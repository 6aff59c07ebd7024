// Volume readers and writers: round trips of every format (gzip variants, both byte orders, every label type), axis
// permutations/flips, and every bad-input case of issue 4 with the file and field named in the message.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "scratch_dir.h"
#include "io/compression.h"
#include "io/error.h"
#include "io/inrimage.h"
#include "io/metaimage.h"
#include "io/nifti.h"
#include "io/nrrd.h"
#include "io/read_volume.h"

namespace fs = std::filesystem;
using namespace cpmesh::io;

namespace {

fs::path temp_dir() { return cpmesh::test::scratch_dir("io_volume"); }

std::string tmp(const std::string& name) { return (temp_dir() / name).string(); }

// A small anisotropic volume with distinct labels per voxel so any reordering shows.
LabelVolume sample_volume(uint16_t max_label) {
  LabelVolume v;
  v.dims = {5, 4, 3};
  v.spacing = {0.5, 1.25, 2.0};
  v.origin = {-3.5, 1.0, 10.25};
  for (int64_t i = 0; i < v.voxel_count(); ++i) v.labels.push_back(uint16_t((i * 7) % (max_label + 1)));
  return v;
}

void check_same(const LabelVolume& a, const LabelVolume& b) {
  CHECK(a.dims == b.dims);
  for (int k = 0; k < 3; ++k) {
    CHECK(a.spacing[k] == doctest::Approx(b.spacing[k]));
    CHECK(a.origin[k] == doctest::Approx(b.origin[k]));
  }
  CHECK(a.labels == b.labels);
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Expects read_label_volume to throw an Error whose message holds every fragment.
void expect_error(const std::string& path, std::initializer_list<std::string> fragments, const RawOptions* raw = nullptr) {
  std::string message;
  try {
    read_label_volume(path, raw);
  } catch (const Error& e) {
    message = e.what();
  }
  INFO("message: " << message);
  REQUIRE(!message.empty());
  for (const auto& f : fragments) CHECK(message.find(f) != std::string::npos);
}

const ScalarType all_int_types[] = {ScalarType::u8, ScalarType::i8, ScalarType::u16,
                                    ScalarType::i16, ScalarType::u32, ScalarType::i32};

uint16_t max_for(ScalarType t) { return t == ScalarType::i8 ? 127 : t == ScalarType::u8 ? 255 : 1000; }

}  // namespace

TEST_CASE("volume round trip: every format, type, byte order and compression") {
  for (ScalarType t : all_int_types)
    for (bool big : {false, true})
      for (bool gz : {false, true}) {
        CAPTURE(scalar_name(t));
        CAPTURE(big);
        CAPTURE(gz);
        const LabelVolume v = sample_volume(max_for(t));
        VolumeWriteOptions o;
        o.type = t;
        o.big_endian = big;
        o.compress = gz;
        const std::string tag = scalar_name(t) + (big ? "_be" : "_le") + (gz ? "_gz" : "");
        write_nrrd(tmp(tag + ".nrrd"), v, o);
        write_nrrd(tmp(tag + ".nhdr"), v, o);
        write_metaimage(tmp(tag + ".mha"), v, o);
        write_metaimage(tmp(tag + ".mhd"), v, o);
        write_nifti(tmp(tag + (gz ? ".nii.gz" : ".nii")), v, o);
        write_inrimage(tmp(tag + (gz ? ".inr.gz" : ".inr")), v, o);
        for (const std::string ext : {".nrrd", ".nhdr", ".mha", ".mhd", gz ? ".nii.gz" : ".nii", gz ? ".inr.gz" : ".inr"}) {
          CAPTURE(ext);
          const LabelVolume r = read_label_volume(tmp(tag + ext));
          check_same(v, r);
          CHECK(r.file_type == t);
        }
      }
}

TEST_CASE("volume format is chosen by content, not by name") {
  const LabelVolume v = sample_volume(9);
  write_nrrd(tmp("looks_like.nii"), v, false);
  CHECK(read_label_volume(tmp("looks_like.nii")).format == "NRRD");
  VolumeWriteOptions o;
  o.compress = true;
  write_nifti(tmp("nifti_named.dat"), v, o);
  const LabelVolume r = read_label_volume(tmp("nifti_named.dat"));
  CHECK(r.format == "NIfTI-1");
  check_same(v, r);
}

TEST_CASE("headerless raw with explicit options, both byte orders") {
  const LabelVolume v = sample_volume(1000);
  for (bool big : {false, true}) {
    write_raw(tmp("v.raw"), v, ScalarType::i16, big);
    RawOptions raw;
    raw.dims = v.dims;
    raw.spacing = v.spacing;
    raw.origin = v.origin;
    raw.type = ScalarType::i16;
    raw.big_endian = big;
    check_same(v, read_label_volume(tmp("v.raw"), &raw));
  }
  expect_error(tmp("v.raw"), {"v.raw", "unrecognised volume format", "--raw-dims"});
  RawOptions wrong;
  wrong.dims = {5, 4, 4};
  wrong.type = ScalarType::i16;
  expect_error(tmp("v.raw"), {"v.raw", "--raw-dims", "truncated"}, &wrong);
}

TEST_CASE("float fields round trip through NRRD") {
  FloatVolume f;
  f.dims = {3, 2, 2};
  f.spacing = {1, 2, 3};
  f.origin = {0.5, 0, -1};
  for (int i = 0; i < 12; ++i) f.values.push_back(float(i) * 0.25f - 1.0f);
  for (bool gz : {false, true}) {
    write_nrrd(tmp("field.nrrd"), f, gz);
    const FloatVolume r = read_float_volume(tmp("field.nrrd"));
    CHECK(r.values == f.values);
    CHECK(r.dims == f.dims);
  }
  expect_error(tmp("field.nrrd"), {"field.nrrd", "field 'type'", "labels must be integers", "float32"});
}

TEST_CASE("axis permutations and flips are applied; oblique directions are refused") {
  // File axes: file x runs along world -z, file y along world x, file z along world y.
  const std::string header =
      "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 3 4\nspace dimension: 3\n"
      "space directions: (0,0,-2) (0.5,0,0) (0,1,0)\nspace origin: (10,20,30)\nencoding: raw\n\n";
  std::string data;
  for (int i = 0; i < 24; ++i) data.push_back(char(i));
  write_text(tmp("permuted.nrrd"), header + data);
  const LabelVolume v = read_label_volume(tmp("permuted.nrrd"));
  REQUIRE(v.dims == std::array<int64_t, 3>{3, 4, 2});
  CHECK(v.spacing == std::array<double, 3>{0.5, 1, 2});
  CHECK(v.origin == std::array<double, 3>{10, 20, 28});
  // File voxel (a,b,c) holds a + 2b + 6c and sits at world index (b, c, 1 - a).
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 3; ++b)
      for (int c = 0; c < 4; ++c) CHECK(v.labels[v.index(b, c, 1 - a)] == a + 2 * b + 6 * c);

  write_text(tmp("oblique.nrrd"),
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 3 4\nspace directions: (0.7071,0.7071,0) (-0.7071,0.7071,0) "
             "(0,0,1)\nencoding: raw\n\n" + data);
  expect_error(tmp("oblique.nrrd"), {"oblique.nrrd", "field 'space directions'", "axis-aligned", "oblique"});

  // A NIfTI sform rotated by 45 degrees about z.
  write_nifti(tmp("oblique.nii"), sample_volume(9), {});
  std::string bytes = read_all(tmp("oblique.nii"));
  const float srow[8] = {0.7071f, -0.7071f, 0, 0, 0.7071f, 0.7071f, 0, 0};
  std::memcpy(bytes.data() + 280, srow, sizeof srow);
  write_text(tmp("oblique.nii"), bytes);
  expect_error(tmp("oblique.nii"), {"oblique.nii", "sform", "axis-aligned"});
}

TEST_CASE("bad input: missing file, directory, unknown content") {
  expect_error(tmp("does_not_exist.nrrd"), {"does_not_exist.nrrd", "not found"});
  expect_error(temp_dir().string(), {temp_dir().string(), "is a directory"});
  write_text(tmp("garbage.bin"), "hello, not a volume");
  expect_error(tmp("garbage.bin"), {"garbage.bin", "unrecognised volume format"});
}

TEST_CASE("bad input: truncated data and sizes that do not match the header") {
  const LabelVolume v = sample_volume(200);
  write_nrrd(tmp("t.nrrd"), v, false);
  const std::string good = read_all(tmp("t.nrrd"));
  write_text(tmp("truncated.nrrd"), good.substr(0, good.size() - 5));
  expect_error(tmp("truncated.nrrd"), {"truncated.nrrd", "field 'data'", "expected 60 bytes", "got 55", "truncated",
                                       "'sizes'"});
  write_text(tmp("extra.nrrd"), good + "xyz");
  expect_error(tmp("extra.nrrd"), {"extra.nrrd", "expected 60 bytes", "got 63", "more data"});

  write_nifti(tmp("t.nii"), v, {});
  const std::string nii = read_all(tmp("t.nii"));
  write_text(tmp("truncated.nii"), nii.substr(0, nii.size() - 1));
  expect_error(tmp("truncated.nii"), {"truncated.nii", "vox_offset", "'dim'", "truncated"});
  write_text(tmp("header_only.nii"), nii.substr(0, 200));
  expect_error(tmp("header_only.nii"), {"header_only.nii", "unrecognised"});

  write_metaimage(tmp("t.mhd"), v, {});
  fs::resize_file(tmp("t.raw"), 10);
  expect_error(tmp("t.mhd"), {"t.mhd", "ElementDataFile", "t.raw", "got 10", "DimSize"});
  fs::remove(tmp("t.raw"));
  expect_error(tmp("t.mhd"), {"t.raw", "not found"});

  VolumeWriteOptions gz;
  gz.compress = true;
  write_inrimage(tmp("t.inr.gz"), v, gz);
  const std::string inr = read_all(tmp("t.inr.gz"));
  write_text(tmp("cut.inr.gz"), inr.substr(0, inr.size() - 20));
  expect_error(tmp("cut.inr.gz"), {"cut.inr.gz", "gzip"});
}

TEST_CASE("bad input: corrupt gzip streams") {
  const LabelVolume v = sample_volume(200);
  write_nrrd(tmp("c.nrrd"), v, true);
  std::string bytes = read_all(tmp("c.nrrd"));
  const size_t data = bytes.find("\n\n") + 2;
  for (size_t i = data + 12; i < bytes.size(); ++i) bytes[i] = char(bytes[i] ^ 0x5a);
  write_text(tmp("corrupt.nrrd"), bytes);
  expect_error(tmp("corrupt.nrrd"), {"corrupt.nrrd", "field 'data'", "compressed data"});
  write_text(tmp("corrupt.nii.gz"), std::string("\x1f\x8b\x08\x00garbage garbage garbage", 27));
  expect_error(tmp("corrupt.nii.gz"), {"corrupt.nii.gz", "gzip"});
}

TEST_CASE("bad input: unknown and float label types") {
  const std::string data(8, '\0');
  write_text(tmp("type.nrrd"), "NRRD0004\ntype: quaternion\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n" + data);
  expect_error(tmp("type.nrrd"), {"type.nrrd", "field 'type'", "expected one of", "quaternion"});
  write_text(tmp("float.nrrd"),
             "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 1\nendian: little\nencoding: raw\n\n" + std::string(16, '\0'));
  expect_error(tmp("float.nrrd"), {"float.nrrd", "field 'type'", "labels must be integers"});
  write_text(tmp("float.mha"), "ObjectType = Image\nNDims = 3\nDimSize = 2 2 1\nElementType = MET_FLOAT\n"
                               "ElementDataFile = LOCAL\n" + std::string(16, '\0'));
  expect_error(tmp("float.mha"), {"float.mha", "field 'ElementType'", "labels must be integers"});
  write_text(tmp("type.mha"), "ObjectType = Image\nNDims = 3\nDimSize = 2 2 1\nElementType = MET_LONG_LONG\n"
                              "ElementDataFile = LOCAL\n" + std::string(32, '\0'));
  expect_error(tmp("type.mha"), {"type.mha", "field 'ElementType'", "MET_LONG_LONG"});
  write_nifti(tmp("dt.nii"), sample_volume(9), {});
  std::string nii = read_all(tmp("dt.nii"));
  nii[70] = 32;  // complex64
  write_text(tmp("dt.nii"), nii);
  expect_error(tmp("dt.nii"), {"dt.nii", "field 'datatype'", "got '32'"});
  // A label that does not fit uint16.
  std::string big;
  store_sample(big, 70000, ScalarType::i32, false);
  write_text(tmp("big.nrrd"), "NRRD0004\ntype: int\ndimension: 3\nsizes: 1 1 1\nendian: little\nencoding: raw\n\n" + big);
  expect_error(tmp("big.nrrd"), {"big.nrrd", "voxel (0,0,0)", "70000"});
  std::string neg;
  store_sample(neg, -2, ScalarType::i8, false);
  write_text(tmp("neg.nrrd"), "NRRD0004\ntype: int8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\n" + neg);
  expect_error(tmp("neg.nrrd"), {"neg.nrrd", "voxel (0,0,0)", "-2"});
}

TEST_CASE("bad input: dims that overflow, exceed memory, or are not positive") {
  write_text(tmp("overflow.nrrd"),
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4294967296 4294967296 4294967296\nencoding: raw\n\nx");
  expect_error(tmp("overflow.nrrd"), {"overflow.nrrd", "field 'sizes'", "voxels in all"});
  write_text(tmp("huge.mha"), "NDims = 3\nDimSize = 3000 3000 1900\nElementType = MET_UCHAR\nElementDataFile = LOCAL\nx");
  // 1.7e10 voxels: below the cap, but more than any test machine's memory (and far more than the one byte present).
  expect_error(tmp("huge.mha"), {"huge.mha", "field 'DimSize'"});
  write_text(tmp("zero.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 64 0 64\nencoding: raw\n\n");
  expect_error(tmp("zero.nrrd"), {"zero.nrrd", "field 'sizes'", "positive integers", "64 0 64"});
  write_text(tmp("few.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 64 64\nencoding: raw\n\n");
  expect_error(tmp("few.nrrd"), {"few.nrrd", "field 'sizes'", "3 positive integers"});
  std::string inr = "#INRIMAGE-4#{\nXDIM=-4\nYDIM=2\nZDIM=2\nTYPE=unsigned fixed\nPIXSIZE=8 bits\n";
  inr += std::string(256 - inr.size() - 4, '\n') + "##}\n";
  write_text(tmp("dims.inr"), inr);
  expect_error(tmp("dims.inr"), {"dims.inr", "field 'XDIM'", "positive"});
}

TEST_CASE("bad input: zero, negative or non-numeric spacing") {
  const std::string data(8, '\0');
  write_text(tmp("zero_spacing.nrrd"),
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: 1 0 1\nencoding: raw\n\n" + data);
  expect_error(tmp("zero_spacing.nrrd"), {"zero_spacing.nrrd", "field 'spacings'", "positive spacings"});
  write_text(tmp("neg_spacing.mha"), "NDims = 3\nDimSize = 2 2 2\nElementSpacing = 1 -1 1\nElementType = MET_UCHAR\n"
                                     "ElementDataFile = LOCAL\n" + data);
  expect_error(tmp("neg_spacing.mha"), {"neg_spacing.mha", "field 'ElementSpacing'", "positive"});
  write_text(tmp("nan_spacing.nrrd"),
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: 1 nan 1\nencoding: raw\n\n" + data);
  expect_error(tmp("nan_spacing.nrrd"), {"nan_spacing.nrrd", "field 'spacings'"});
  LabelVolume v = sample_volume(9);
  v.spacing[2] = 0;
  write_nifti(tmp("zero_pixdim.nii"), v, {});
  expect_error(tmp("zero_pixdim.nii"), {"zero_pixdim.nii", "sform", "positive spacings"});
}

TEST_CASE("writes are atomic: a failed write leaves nothing under the final name") {
  LabelVolume v = sample_volume(9);
  v.labels.push_back(1);  // inconsistent with dims
  CHECK_THROWS_AS(write_nrrd(tmp("never.nrrd"), v, false), Error);
  CHECK(!fs::exists(tmp("never.nrrd")));
  for (const auto& e : fs::directory_iterator(temp_dir()))
    CHECK(e.path().string().find(".tmp-") == std::string::npos);
  CHECK_THROWS_WITH_AS(write_nrrd((temp_dir() / "no_such_dir" / "x.nrrd").string(), sample_volume(9), false),
                       doctest::Contains("cannot create"), Error);
}
