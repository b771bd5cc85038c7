// ohm_gdcm.cpp — one DICOM series as a volume, through GDCM (ohm_gdcm.h).
// Every exported function body runs inside OHM_GDCM_TRY ... OHM_GDCM_CATCH,
// so no C++ exception crosses into C.

#include "ohm_gdcm.h"
#include "dicom_check.h"

#include <gdcmDataSet.h>
#include <gdcmDirectory.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmReader.h>
#include <gdcmScanner.h>
#include <gdcmSequenceOfItems.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <new>
#include <string>
#include <vector>

// GDCM's own warnings and errors go to stderr; ohm reports in its own
// one-line messages, so they are switched off (gdcm::Trace's process-wide
// flags, GDCM's state, not ohm's) on entry to each reading function.
#define OHM_GDCM_TRY                                                                              \
    try {                                                                                         \
        gdcm::Trace::WarningOff();                                                                \
        gdcm::Trace::ErrorOff();
#define OHM_GDCM_CATCH(err, path)                                                                 \
    }                                                                                             \
    catch (const std::bad_alloc &) {                                                              \
        return ohm_fail((err), OHM_ERR_NOMEM, "%s: DICOM: out of memory", (path));                \
    }                                                                                             \
    catch (const std::exception &e_) {                                                            \
        return ohm_fail((err), OHM_ERR_INTERNAL, "%s: GDCM wrapper: %s", (path), e_.what());      \
    }                                                                                             \
    catch (...) {                                                                                 \
        return ohm_fail((err), OHM_ERR_INTERNAL, "%s: GDCM wrapper: unknown exception", (path));  \
    }

namespace {

const gdcm::Tag T_SERIES(0x0020, 0x000e), T_POSITION(0x0020, 0x0032), T_ORIENTATION(0x0020, 0x0037),
    T_ROWS(0x0028, 0x0010), T_COLUMNS(0x0028, 0x0011), T_SPACING(0x0028, 0x0030), T_THICKNESS(0x0018, 0x0050),
    T_DESCRIPTION(0x0008, 0x103e), T_FRAMES(0x0028, 0x0008), T_SLOPE(0x0028, 0x1053), T_SAMPLES(0x0028, 0x0002),
    T_BITS_ALLOCATED(0x0028, 0x0100), T_BITS_STORED(0x0028, 0x0101), T_PIXEL_SIGN(0x0028, 0x0103),
    T_INTERCEPT(0x0028, 0x1052), T_RECORDS(0x0004, 0x1220), T_FILE_ID(0x0004, 0x1500), T_PIXEL_DATA(0x7fe0, 0x0010);

// Up to n backslash-separated numbers of a DICOM decimal string; how many,
// -1 when something else is there.
int numbers(const char *text, double *out, int n)
{
    if (!text) return 0;
    int k = 0;
    const char *p = text;
    while (*p == ' ') ++p;
    while (k < n && *p) {
        char *end;
        double v = std::strtod(p, &end);
        if (end == p || !std::isfinite(v)) return -1;
        out[k++] = v;
        p = end;
        while (*p == ' ') ++p;
        if (*p == '\\') ++p;
        else break;
    }
    return k;
}

std::string trimmed(const char *text)
{
    std::string s = text ? text : "";
    while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
    size_t start = s.find_first_not_of(' ');
    return start == std::string::npos ? std::string() : s.substr(start);
}

const char *base_name(const std::string &path)
{
    const char *slash = std::strrchr(path.c_str(), '/');
    return slash ? slash + 1 : path.c_str();
}

std::string folder_of(const std::string &path)
{
    size_t slash = path.rfind('/');
    return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

bool is_folder(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

bool is_file(const std::string &path)
{
    struct stat st;
    return stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// How one slice's stored samples become values (PS3.3 C.7.6.3, C.11.1).
struct Samples {
    int bits, stored;        // BitsAllocated (8, 16, 32), BitsStored
    bool is_signed;          // PixelRepresentation 1: two's complement
    double slope, intercept; // RescaleSlope, RescaleIntercept
};

struct Slice {
    std::string file;
    double position[3], along; // ImagePositionPatient; its distance along the normal
    Samples samples;
};

struct Series {
    std::vector<std::string> files;
    std::string description;
};

// The files a DICOMDIR's records reference (ReferencedFileID, its
// components joined by '/' under the DICOMDIR's folder; PS3.10 8.5).
int dicomdir_files(std::vector<std::string> &files, const std::string &dicomdir, ohm_error *err)
{
    std::string why;
    if (!ohm_dicom::has_part10_mark(dicomdir))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: no DICM mark after a 128-byte preamble: not a DICOMDIR",
                        dicomdir.c_str());
    if (!ohm_dicom::lengths_fit(dicomdir, why)) return ohm_fail(err, OHM_ERR_PARSE, "%s: %s", dicomdir.c_str(), why.c_str());
    gdcm::Reader reader;
    reader.SetFileName(dicomdir.c_str());
    if (!reader.Read())
        return ohm_fail(err, OHM_ERR_PARSE, "%s: GDCM cannot read the DICOMDIR", dicomdir.c_str());
    const gdcm::DataSet &ds = reader.GetFile().GetDataSet();
    if (!ds.FindDataElement(T_RECORDS))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: no Directory Record Sequence (0004,1220): not a DICOMDIR",
                        dicomdir.c_str());
    gdcm::SmartPointer<gdcm::SequenceOfItems> records = ds.GetDataElement(T_RECORDS).GetValueAsSQ();
    if (!records) return ohm_fail(err, OHM_ERR_PARSE, "%s: unreadable Directory Record Sequence", dicomdir.c_str());
    const std::string root = folder_of(dicomdir);
    for (gdcm::SequenceOfItems::SizeType i = 1; i <= records->GetNumberOfItems(); ++i) {
        const gdcm::DataSet &record = records->GetItem(i).GetNestedDataSet();
        if (!record.FindDataElement(T_FILE_ID)) continue; // a patient, study or series record
        const gdcm::ByteValue *id = record.GetDataElement(T_FILE_ID).GetByteValue();
        if (!id) continue;
        std::string rel = trimmed(std::string(id->GetPointer(), id->GetLength()).c_str());
        std::replace(rel.begin(), rel.end(), '\\', '/');
        if (rel.empty() || rel[0] == '/' || rel.find("..") != std::string::npos)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: record %u references '%s', expected a path inside its folder",
                            dicomdir.c_str(), (unsigned)i, rel.c_str());
        std::string file = root + "/" + rel;
        if (!is_file(file))
            return ohm_fail(err, OHM_ERR_IO, "%s: record %u references %s, which is missing", dicomdir.c_str(),
                            (unsigned)i, file.c_str());
        files.push_back(file);
    }
    if (files.empty()) return ohm_fail(err, OHM_ERR_PARSE, "%s: the DICOMDIR references no files", dicomdir.c_str());
    return 0;
}

// The files to scan: a folder's (through its DICOMDIR when it has one), a
// DICOMDIR's, or a single file's folder's.
int candidate_files(std::vector<std::string> &files, const char *path, ohm_error *err)
{
    if (!is_folder(path)) {
        if (std::strcmp(base_name(path), "DICOMDIR") == 0) return dicomdir_files(files, path, err);
        std::string dir = folder_of(path);
        if (is_file(dir + "/DICOMDIR")) return dicomdir_files(files, dir + "/DICOMDIR", err);
        gdcm::Directory d;
        d.Load(dir, false);
        files = d.GetFilenames();
        return 0;
    }
    std::string dicomdir = std::string(path) + "/DICOMDIR";
    if (is_file(dicomdir)) return dicomdir_files(files, dicomdir, err);
    gdcm::Directory d;
    if (d.Load(path, false) == 0) return ohm_fail(err, OHM_ERR_PARSE, "%s: no files in the folder", path);
    files = d.GetFilenames();
    return 0;
}

// The files' series: UID -> files (DICOM images only).
int group_series(std::map<std::string, Series> &series, gdcm::Scanner &scanner,
                 const std::vector<std::string> &files, const char *path, ohm_error *err)
{
    for (gdcm::Tag t : {T_SERIES, T_POSITION, T_ORIENTATION, T_ROWS, T_COLUMNS, T_SPACING, T_THICKNESS,
                        T_DESCRIPTION, T_FRAMES, T_SLOPE, T_SAMPLES,
                        T_BITS_ALLOCATED, T_BITS_STORED, T_PIXEL_SIGN, T_INTERCEPT})
        scanner.AddTag(t);
    // only DICOM Part 10 files, each checked before GDCM allocates what it declares
    std::vector<std::string> dicom;
    for (const std::string &f : files) {
        if (!ohm_dicom::has_part10_mark(f)) continue;
        std::string why;
        if (!ohm_dicom::lengths_fit(f, why)) return ohm_fail(err, OHM_ERR_PARSE, "%s: %s", f.c_str(), why.c_str());
        dicom.push_back(f);
    }
    if (!scanner.Scan(dicom)) return ohm_fail(err, OHM_ERR_IO, "%s: GDCM could not scan the files", path);
    for (const std::string &f : dicom) {
        if (!scanner.IsKey(f.c_str())) continue; // not DICOM
        const char *uid = scanner.GetValue(f.c_str(), T_SERIES), *rows = scanner.GetValue(f.c_str(), T_ROWS);
        if (!uid || !rows) continue; // not an image of a series
        Series &s = series[trimmed(uid)];
        s.files.push_back(f);
        if (s.description.empty()) s.description = trimmed(scanner.GetValue(f.c_str(), T_DESCRIPTION));
    }
    if (series.empty()) return ohm_fail(err, OHM_ERR_PARSE, "%s: no DICOM images found", path);
    return 0;
}

int choose_series(std::string &uid, const std::map<std::string, Series> &series, const char *path,
                  const std::string &asked, ohm_error *err)
{
    if (!asked.empty()) {
        if (series.count(asked)) return uid = asked, 0;
    } else if (series.size() == 1) {
        return uid = series.begin()->first, 0;
    }
    std::string list;
    for (const auto &s : series) {
        char one[320];
        std::snprintf(one, sizeof one, "%s%s (%zu slices%s%.64s)", list.empty() ? "" : ", ", s.first.c_str(),
                      s.second.files.size(), s.second.description.empty() ? "" : ", ",
                      s.second.description.c_str());
        list += one;
    }
    if (!asked.empty())
        return ohm_fail(err, OHM_ERR_USAGE, "%s: no series %s here; there are %s", path, asked.c_str(), list.c_str());
    return ohm_fail(err, OHM_ERR_USAGE, "%s: %zu series here, choose one with series=UID: %s", path, series.size(),
                    list.c_str());
}

// One slice's geometry tags, checked against the first slice's.
struct Frame {
    double orient[6], spacing[2]; // ImageOrientationPatient; PixelSpacing (between rows, between columns)
    int64_t cols, rows;
};

// A grey-level image of 8, 16 or 32-bit integers and its rescale.  Checked
// here, before GDCM's ImageReader sees the file: it asserts (aborts) on
// 2 samples per pixel, and reads a RescaleSlope of 0 as 1.
int slice_samples(Samples &px, const char *file, gdcm::Scanner &scanner, ohm_error *err)
{
    double samples = 1, bits = 0, stored = 0, sign = 0, slope = 1, intercept = 0;
    if (numbers(scanner.GetValue(file, T_SAMPLES), &samples, 1) < 0 || samples != 1)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %g samples per pixel (0028,0002), expected one (a grey-level image)",
                        file, samples);
    if (numbers(scanner.GetValue(file, T_BITS_ALLOCATED), &bits, 1) != 1 || !(bits == 8 || bits == 16 || bits == 32))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: BitsAllocated (0028,0100) %g, expected 8, 16 or 32", file, bits);
    int got = numbers(scanner.GetValue(file, T_BITS_STORED), &stored, 1);
    if (got == 0) stored = bits;
    if (got < 0 || !(stored >= 1 && stored <= bits) || stored != std::floor(stored))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: BitsStored (0028,0101) %g, expected 1 to BitsAllocated (%g)", file,
                        stored, bits);
    if (numbers(scanner.GetValue(file, T_PIXEL_SIGN), &sign, 1) < 0 || !(sign == 0 || sign == 1))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: PixelRepresentation (0028,0103) %g, expected 0 (unsigned) or 1 "
                                            "(signed)", file, sign);
    const char *slope_text = scanner.GetValue(file, T_SLOPE);
    if (numbers(slope_text, &slope, 1) < 0 || slope == 0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: RescaleSlope (0028,1053) '%s': expected a finite, non-zero slope",
                        file, trimmed(slope_text).c_str());
    const char *intercept_text = scanner.GetValue(file, T_INTERCEPT);
    if (numbers(intercept_text, &intercept, 1) < 0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: RescaleIntercept (0028,1052) '%s': expected a finite number", file,
                        trimmed(intercept_text).c_str());
    px = Samples{(int)bits, (int)stored, sign == 1, slope, intercept};
    return 0;
}

int slice_frame(Frame &f, Samples &px, double position[3], const char *file, gdcm::Scanner &scanner, ohm_error *err)
{
    if (numbers(scanner.GetValue(file, T_ORIENTATION), f.orient, 6) != 6)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: no ImageOrientationPatient (0020,0037), expected six direction "
                                            "cosines", file);
    if (numbers(scanner.GetValue(file, T_POSITION), position, 3) != 3)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: no ImagePositionPatient (0020,0032), expected the slice's position",
                        file);
    if (numbers(scanner.GetValue(file, T_SPACING), f.spacing, 2) != 2 || !(f.spacing[0] > 0) || !(f.spacing[1] > 0))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: no positive PixelSpacing (0028,0030)", file);
    double r = 0, c = 0, frames = 1;
    numbers(scanner.GetValue(file, T_ROWS), &r, 1);
    numbers(scanner.GetValue(file, T_COLUMNS), &c, 1);
    numbers(scanner.GetValue(file, T_FRAMES), &frames, 1);
    if (!(r >= 1 && r <= 65535 && c >= 1 && c <= 65535))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %g x %g pixels, expected 1 to 65535 each way", file, c, r);
    if (frames != 1)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %g frames in one file (an enhanced multi-frame image): ohm reads "
                                            "series of single-frame slices", file, frames);
    int rc = slice_samples(px, file, scanner, err);
    if (rc) return rc;
    f.cols = (int64_t)c;
    f.rows = (int64_t)r;
    double a[3] = {f.orient[0], f.orient[1], f.orient[2]}, b[3] = {f.orient[3], f.orient[4], f.orient[5]};
    double la = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    if (std::fabs(la - 1) > 1e-3 || std::fabs(lb - 1) > 1e-3 || std::fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) > 1e-3)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: ImageOrientationPatient %g\\%g\\%g\\%g\\%g\\%g: expected two "
                                            "perpendicular unit vectors", file, a[0], a[1], a[2], b[0], b[1], b[2]);
    return 0;
}

int same_frame(const Frame &f, const Frame &first, const char *file, const std::string &first_file, ohm_error *err)
{
    for (int q = 0; q < 6; ++q)
        if (std::fabs(f.orient[q] - first.orient[q]) > 1e-4)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: orientation %g\\%g\\%g\\%g\\%g\\%g differs from %s's: one series "
                                                "must have one orientation", file, f.orient[0], f.orient[1],
                            f.orient[2], f.orient[3], f.orient[4], f.orient[5], base_name(first_file));
    if (f.cols != first.cols || f.rows != first.rows)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %lld x %lld pixels, %s has %lld x %lld: mixed slice sizes", file,
                        (long long)f.cols, (long long)f.rows, base_name(first_file), (long long)first.cols,
                        (long long)first.rows);
    for (int q = 0; q < 2; ++q)
        if (std::fabs(f.spacing[q] - first.spacing[q]) > 1e-4 * first.spacing[q])
            return ohm_fail(err, OHM_ERR_PARSE, "%s: pixel spacing %g\\%g differs from %s's %g\\%g", file,
                            f.spacing[0], f.spacing[1], base_name(first_file), first.spacing[0], first.spacing[1]);
    return 0;
}

void slice_normal(const double orient[6], double n[3])
{
    n[0] = orient[1] * orient[5] - orient[2] * orient[4];
    n[1] = orient[2] * orient[3] - orient[0] * orient[5];
    n[2] = orient[0] * orient[4] - orient[1] * orient[3];
}

// Sorted along the normal; no duplicate positions, no gaps.
int check_spacing(const std::vector<Slice> &slices, const Frame &frame, const char *path, ohm_error *err)
{
    if (slices.size() < 2) return 0;
    const double step = (slices.back().along - slices.front().along) / (double)(slices.size() - 1);
    const double fine = std::min(frame.spacing[0], frame.spacing[1]);
    for (size_t k = 1; k < slices.size(); ++k) {
        double gap = slices[k].along - slices[k - 1].along;
        if (gap < 1e-3 * fine)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: %s and %s are at the same position (%g mm along the normal): a "
                                                "duplicated slice", path, base_name(slices[k - 1].file),
                            base_name(slices[k].file), slices[k].along);
        if (std::fabs(gap - step) > 0.01 * step + 1e-4)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: %g mm between %s and %s where the series' slices are %g mm "
                                                "apart on average: a missing slice (or an uneven series), refused",
                            path, gap, base_name(slices[k - 1].file), base_name(slices[k].file), step);
    }
    return 0;
}

// n stored samples (little- or big-endian) as values: the bits outside
// BitsStored dropped, two's complement from BitsStored when signed (PS3.5
// 8.1.1), then rescaled.
void decode_samples(float *out, const unsigned char *in, size_t n, const Samples &px, bool big_endian)
{
    const size_t each = (size_t)px.bits / 8;
    const uint64_t mask = ((uint64_t)1 << px.stored) - 1, sign_bit = (uint64_t)1 << (px.stored - 1);
    for (size_t i = 0; i < n; ++i) {
        const unsigned char *b = in + i * each;
        uint64_t u = 0;
        for (size_t q = 0; q < each; ++q) u |= (uint64_t)b[big_endian ? each - 1 - q : q] << (8 * q);
        u &= mask;
        const int64_t v = px.is_signed && (u & sign_bit) ? (int64_t)u - ((int64_t)1 << px.stored) : (int64_t)u;
        out[i] = (float)((double)v * px.slope + px.intercept);
    }
}

// One slice's pixels, rescaled, into out (cols x rows).  Native
// (uncompressed) pixel data is decoded here from the PixelData element;
// compressed (encapsulated) data is decompressed by GDCM's ImageReader.
int read_slice(float *out, int64_t *rescaled, const Slice &slice, int64_t cols, int64_t rows, ohm_error *err)
{
    const char *file = slice.file.c_str();
    const Samples &px = slice.samples;
    const size_t n = (size_t)cols * (size_t)rows, want = n * (size_t)(px.bits / 8);
    gdcm::Reader reader;
    reader.SetFileName(file);
    if (!reader.Read()) return ohm_fail(err, OHM_ERR_PARSE, "%s: GDCM cannot parse the file", file);
    const gdcm::TransferSyntax &ts = reader.GetFile().GetHeader().GetDataSetTransferSyntax();
    std::vector<char> decompressed;
    const unsigned char *stored = NULL;
    size_t have = 0;
    gdcm::ImageReader image_reader;
    if (ts.IsEncapsulated()) {
        image_reader.SetFileName(file);
        if (!image_reader.Read())
            return ohm_fail(err, OHM_ERR_PARSE, "%s: GDCM cannot read the compressed image (%s)", file,
                            gdcm::TransferSyntax::GetTSString(ts));
        const gdcm::Image &img = image_reader.GetImage();
        if ((int64_t)img.GetDimension(0) != cols || (int64_t)img.GetDimension(1) != rows ||
            img.GetPixelFormat().GetBitsAllocated() != px.bits)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: the compressed image is %u x %u of %u bits, its header says %lld x "
                                                "%lld of %d", file, img.GetDimension(0), img.GetDimension(1),
                            img.GetPixelFormat().GetBitsAllocated(), (long long)cols, (long long)rows, px.bits);
        decompressed.resize(img.GetBufferLength());
        if (!img.GetBuffer(decompressed.data()))
            return ohm_fail(err, OHM_ERR_PARSE, "%s: the compressed pixel data cannot be decoded", file);
        stored = (const unsigned char *)decompressed.data();
        have = decompressed.size();
    } else {
        const gdcm::DataSet &ds = reader.GetFile().GetDataSet();
        const gdcm::ByteValue *pixels =
            ds.FindDataElement(T_PIXEL_DATA) ? ds.GetDataElement(T_PIXEL_DATA).GetByteValue() : NULL;
        if (!pixels) return ohm_fail(err, OHM_ERR_PARSE, "%s: no PixelData (7fe0,0010)", file);
        stored = (const unsigned char *)pixels->GetPointer();
        have = pixels->GetLength(); // held to the file by dicom_check
    }
    if (have < want)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: truncated pixel data: %zu bytes for %lld x %lld pixels of %d bits",
                        file, have, (long long)cols, (long long)rows, px.bits);
    // GDCM's decompressed buffer is in the machine's order (little-endian here)
    decode_samples(out, stored, n, px, !ts.IsEncapsulated() && ts.GetSwapCode() == gdcm::SwapCode::BigEndian);
    *rescaled += px.slope != 1 || px.intercept != 0;
    return 0;
}

} // namespace

struct ohm_dicom_series {
    std::string path, uid;
    std::vector<Slice> slices; // sorted along the normal
    int64_t dims[3];
    double index_to_world[3][4];
};

namespace {

// Sort and check the chosen series' slices; set its geometry.
int build_series(ohm_dicom_series &out, const Series &s, gdcm::Scanner &scanner, ohm_error *err)
{
    Frame first = {}, f = {};
    std::string first_file;
    for (const std::string &file : s.files) {
        Slice sl{file, {0, 0, 0}, 0, Samples{}};
        int rc = slice_frame(first_file.empty() ? first : f, sl.samples, sl.position, file.c_str(), scanner, err);
        if (!rc && !first_file.empty()) rc = same_frame(f, first, file.c_str(), first_file, err);
        if (rc) return rc;
        if (first_file.empty()) first_file = file;
        out.slices.push_back(sl);
    }
    double n[3];
    slice_normal(first.orient, n);
    for (Slice &sl : out.slices) sl.along = sl.position[0] * n[0] + sl.position[1] * n[1] + sl.position[2] * n[2];
    std::sort(out.slices.begin(), out.slices.end(), [](const Slice &a, const Slice &b) { return a.along < b.along; });
    int rc = check_spacing(out.slices, first, out.path.c_str(), err);
    if (rc) return rc;
    // columns step along the row direction by the spacing between columns
    // (PixelSpacing's second value), rows along the column direction by the
    // spacing between rows; slices by the step between their positions
    // (DICOM PS3.3 C.7.6.2.1.1, equation C.7.6.2.1-1)
    const int64_t nz = (int64_t)out.slices.size();
    double thickness = 0;
    numbers(scanner.GetValue(out.slices[0].file.c_str(), T_THICKNESS), &thickness, 1);
    for (int r = 0; r < 3; ++r) {
        out.index_to_world[r][0] = first.orient[r] * first.spacing[1];
        out.index_to_world[r][1] = first.orient[3 + r] * first.spacing[0];
        out.index_to_world[r][2] = nz > 1 ? (out.slices.back().position[r] - out.slices.front().position[r]) / (double)(nz - 1)
                                          : n[r] * (thickness > 0 ? thickness : first.spacing[0]);
        out.index_to_world[r][3] = out.slices.front().position[r];
    }
    out.dims[0] = first.cols;
    out.dims[1] = first.rows;
    out.dims[2] = nz;
    return 0;
}

} // namespace

extern "C" int ohm_dicom_is_file(const char *path)
{
    try {
        return std::strcmp(base_name(path), "DICOMDIR") == 0 || ohm_dicom::has_part10_mark(path);
    } catch (...) {
        return 0;
    }
}

extern "C" int ohm_dicom_folder_has_dicom(const char *dir)
{
    try {
        if (is_file(std::string(dir) + "/DICOMDIR")) return 1;
        gdcm::Directory d;
        if (d.Load(dir, false) == 0) return 0;
        for (const std::string &f : d.GetFilenames())
            if (ohm_dicom::has_part10_mark(f)) return 1;
        return 0;
    } catch (...) {
        return 0;
    }
}

extern "C" int ohm_dicom_open(ohm_dicom_series **out, const char *path, const char *series_uid, ohm_error *err)
{
    *out = NULL;
    OHM_GDCM_TRY
    std::vector<std::string> files;
    int rc = candidate_files(files, path, err);
    if (rc) return rc;
    std::map<std::string, Series> series;
    gdcm::Scanner scanner;
    rc = group_series(series, scanner, files, path, err);
    if (rc) return rc;
    std::string asked = series_uid ? trimmed(series_uid) : std::string();
    if (asked.empty() && !is_folder(path) && std::strcmp(base_name(path), "DICOMDIR") != 0) {
        if (!ohm_dicom::has_part10_mark(path))
            return ohm_fail(err, OHM_ERR_PARSE, "%s: no DICM mark after a 128-byte preamble: not a DICOM file", path);
        if (!scanner.IsKey(path))
            return ohm_fail(err, OHM_ERR_PARSE, "%s: not a readable DICOM file (GDCM cannot parse it)", path);
        const char *own = scanner.GetValue(path, T_SERIES);
        if (!own || !scanner.GetValue(path, T_ROWS))
            return ohm_fail(err, OHM_ERR_PARSE, "%s: not an image of a DICOM series (no SeriesInstanceUID or Rows)",
                            path);
        asked = trimmed(own);
    }
    std::string uid;
    rc = choose_series(uid, series, path, asked, err);
    if (rc) return rc;
    ohm_dicom_series *s = new ohm_dicom_series();
    s->path = path;
    s->uid = uid;
    rc = build_series(*s, series[uid], scanner, err);
    if (rc) {
        delete s;
        return rc;
    }
    *out = s;
    return 0;
    OHM_GDCM_CATCH(err, path)
}

extern "C" void ohm_dicom_geometry(const ohm_dicom_series *s, int64_t dims[3], double index_to_world[3][4])
{
    std::memcpy(dims, s->dims, sizeof s->dims);
    std::memcpy(index_to_world, s->index_to_world, sizeof s->index_to_world);
}

extern "C" const char *ohm_dicom_series_uid(const ohm_dicom_series *s) { return s->uid.c_str(); }

extern "C" void ohm_dicom_sizes(const ohm_dicom_series *s, double *stored_bytes, double *slice_bytes)
{
    *stored_bytes = *slice_bytes = 0;
    for (const Slice &slice : s->slices) {
        struct stat st;
        if (stat(slice.file.c_str(), &st) == 0) *stored_bytes += (double)st.st_size;
        const double bytes = (double)s->dims[0] * (double)s->dims[1] * (slice.samples.bits / 8);
        if (bytes > *slice_bytes) *slice_bytes = bytes;
    }
}

extern "C" int ohm_dicom_read_voxels(ohm_dicom_series *s, float *out, int64_t *rescaled, ohm_error *err)
{
    *rescaled = 0;
    OHM_GDCM_TRY
    const size_t per_slice = (size_t)s->dims[0] * (size_t)s->dims[1];
    for (size_t k = 0; k < s->slices.size(); ++k) {
        int rc = read_slice(out + k * per_slice, rescaled, s->slices[k], s->dims[0], s->dims[1], err);
        if (rc) return rc;
    }
    return 0;
    OHM_GDCM_CATCH(err, s->path.c_str())
}

extern "C" void ohm_dicom_close(ohm_dicom_series *s) { delete s; }
