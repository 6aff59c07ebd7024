#pragma once
// NIfTI-1 single-file images (.nii; .nii.gz is the same file gzip-compressed as a whole), either byte order.
// World coordinates are the file's own (RAS for NIfTI): sform when set, else qform, else pixdim scaling.
#include <string>
#include <string_view>

#include "io/volume_layout.h"
#include "io/volume_writer_options.h"

namespace cpmesh::io {

bool is_nifti(std::string_view head);
VolumeLayout parse_nifti_header(const std::string& file, std::string_view head);

// `o.compress` gzips the whole file (name it .nii.gz).
void write_nifti(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o);

}  // namespace cpmesh::io
