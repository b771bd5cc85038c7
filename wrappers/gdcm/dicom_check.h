// dicom_check.h — the shim's own pass over a DICOM file before GDCM reads
// it (internal to wrappers/gdcm).  GDCM allocates every data element's
// declared length before reading its bytes, so a 1 KB file that declares a
// 4 GB element costs 4 GB (found by scripts/fuzz.sh dicom).  This walks the
// file's elements, items and fragments (PS3.5 7.1-7.5, A.4) without
// allocating and refuses any length that runs past the end of the file.
#ifndef OHM_DICOM_CHECK_H
#define OHM_DICOM_CHECK_H

#include <string>

namespace ohm_dicom {

// True when the file starts like DICOM Part 10: a 128-byte preamble, "DICM".
bool has_part10_mark(const std::string &path);

// True when every declared length fits in the file; otherwise false with why
// ("data element (7fe0,0010) at byte 1204 declares 943206704 bytes, 12 remain").
// A deflated dataset is not walked (its lengths are inside the deflate stream).
bool lengths_fit(const std::string &path, std::string &why);

} // namespace ohm_dicom

#endif
