// dicom_check.cpp — every declared length of a DICOM file checked against
// the file, before GDCM allocates it (dicom_check.h).
//
// The layout (PS3.10 7.1; PS3.5 7.1): a 128-byte preamble, "DICM", the file
// meta group (0002) in explicit VR little endian, then the dataset in the
// transfer syntax (0002,0010) names.  An element is a tag (group, element),
// in explicit VR two VR characters, and a length: 2 bytes, or 2 reserved +
// 4 for the VRs of PS3.5 Table 7.1-1 (OB, OD, OF, OL, OV, OW, SQ, SV, UC,
// UN, UR, UT, UV); implicit VR always 4.  0xFFFFFFFF is an undefined length:
// a sequence of items (FFFE,E000), each a dataset of defined length or one
// ended by (FFFE,E00D), closed by (FFFE,E0DD); or encapsulated pixel data,
// fragments (FFFE,E000) of defined length, closed the same way (A.4).

#include "dicom_check.h"

#include <gdcmDict.h>
#include <gdcmDicts.h>
#include <gdcmGlobal.h>
#include <gdcmTag.h>
#include <gdcmVR.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>

namespace ohm_dicom {
namespace {

const uint32_t UNDEFINED = 0xffffffffu;
const int MAX_DEPTH = 64; // nested sequences deeper than this are refused

struct Walker {
    const unsigned char *b;
    size_t n;
    bool big = false;           // explicit VR big endian (retired, PS3.5 A.3)
    bool implicit_vr = false;   // implicit VR little endian (PS3.5 A.1)
    bool in_meta = true;        // still in the file meta group (0002), which opens the file
    bool saw_syntax = false;    // its TransferSyntaxUID (0002,0010) was read
    size_t meta_end = 0;        // where its group length (0002,0000) says it ends
    std::string why;

    uint16_t u16(size_t at, bool meta) const
    {
        return (!meta && big) ? (uint16_t)(b[at] << 8 | b[at + 1]) : (uint16_t)(b[at] | b[at + 1] << 8);
    }
    uint32_t u32(size_t at, bool meta) const
    {
        return (!meta && big) ? (uint32_t)b[at] << 24 | (uint32_t)b[at + 1] << 16 | (uint32_t)b[at + 2] << 8 | b[at + 3]
                              : (uint32_t)b[at] | (uint32_t)b[at + 1] << 8 | (uint32_t)b[at + 2] << 16 |
                                    (uint32_t)b[at + 3] << 24;
    }
    bool fail(const char *fmt, ...) __attribute__((format(printf, 2, 3)))
    {
        char msg[200];
        va_list ap;
        va_start(ap, fmt);
        std::vsnprintf(msg, sizeof msg, fmt, ap);
        va_end(ap);
        why = msg;
        return false;
    }
    bool cut(size_t at) { return fail("the file ends inside a data element's header at byte %zu", at); }
    bool too_long(const char *what, unsigned group, unsigned elem, size_t at, uint32_t len, size_t left)
    {
        return fail("%s (%04x,%04x) at byte %zu declares %u bytes, only %zu remain: the file is truncated or corrupt",
                    what, group, elem, at, len, left);
    }

    bool dataset(size_t &pos, size_t end, int depth, bool until_item_end);
    bool sequence(size_t &pos, int depth);
    bool fragments(size_t &pos);
};

// The value representations of PS3.5 6.2 (Table 6.2-1).
bool known_vr(const unsigned char *vr)
{
    static const char vrs[] = "AEASATCSDADSDTFLFDISLOLTOBODOFOLOVOWPNSHSLSQSSSTSVTMUCUIULUNURUSUTUV";
    for (size_t i = 0; vrs[i]; i += 2)
        if (vr[0] == vrs[i] && vr[1] == vrs[i + 1]) return true;
    return false;
}

// Whether an explicit VR agrees with GDCM's dictionary for the groups its
// image reader reads through gdcm::Attribute (0008 SOP, 0018 acquisition,
// 0020 geometry, 0028 image pixel): Attribute::SetFromDataElement asserts
// (aborts) on a VR the dictionary does not allow.
bool vr_agrees(uint16_t group, uint16_t elem, const unsigned char *vr)
{
    if (group != 0x0008 && group != 0x0018 && group != 0x0020 && group != 0x0028) return true;
    const gdcm::VR expected = gdcm::Global::GetInstance().GetDicts().GetPublicDict().GetDictEntry(gdcm::Tag(group, elem)).GetVR();
    if (expected == gdcm::VR::INVALID || expected == gdcm::VR::VR_END) return true; // not in the dictionary
    const char text[3] = {(char)vr[0], (char)vr[1], 0};
    return expected.Compatible(gdcm::VR(gdcm::VR::GetVRType(text)));
}

bool long_length_vr(const unsigned char *vr)
{
    static const char *vrs[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"};
    for (const char *v : vrs)
        if (vr[0] == v[0] && vr[1] == v[1]) return true;
    return false;
}

bool Walker::sequence(size_t &pos, int depth)
{
    for (;;) {
        if (n - pos < 8) return cut(pos);
        const uint16_t group = u16(pos, false), elem = u16(pos + 2, false);
        const uint32_t len = u32(pos + 4, false);
        if (group != 0xfffe)
            return fail("a sequence holds (%04x,%04x) at byte %zu where an item was expected", group, elem, pos);
        pos += 8;
        if (elem == 0xe0dd) return true; // sequence end
        if (elem != 0xe000) return fail("unexpected (%04x,%04x) at byte %zu in a sequence", group, elem, pos - 8);
        if (len == UNDEFINED) {
            if (!dataset(pos, n, depth + 1, true)) return false;
        } else {
            if (len > n - pos) return too_long("item", group, elem, pos - 8, len, n - pos);
            size_t item_end = pos + len;
            if (!dataset(pos, item_end, depth + 1, false)) return false;
            pos = item_end;
        }
    }
}

bool Walker::fragments(size_t &pos)
{
    for (;;) {
        if (n - pos < 8) return cut(pos);
        const uint16_t group = u16(pos, false), elem = u16(pos + 2, false);
        const uint32_t len = u32(pos + 4, false);
        pos += 8;
        if (group == 0xfffe && elem == 0xe0dd) return true;
        if (group != 0xfffe || elem != 0xe000 || len == UNDEFINED)
            return fail("encapsulated pixel data holds (%04x,%04x) at byte %zu, expected a fragment", group, elem,
                        pos - 8);
        if (len > n - pos) return too_long("fragment", group, elem, pos - 8, len, n - pos);
        pos += len;
    }
}

bool Walker::dataset(size_t &pos, size_t end, int depth, bool until_item_end)
{
    if (depth > MAX_DEPTH) return fail("sequences nested more than %d deep", MAX_DEPTH);
    while (pos < end) {
        if (end - pos < 8) return cut(pos);
        // the meta group (explicit VR little endian) opens the file; the
        // dataset follows in the transfer syntax it names
        const bool meta = in_meta && depth == 0 && u16(pos, true) == 0x0002;
        if (depth == 0 && in_meta && !meta) {
            if (!saw_syntax)
                return fail("no TransferSyntaxUID (0002,0010) in a file meta group (0002) opening the file, at byte "
                            "%zu: not a DICOM Part 10 file", pos);
            if (pos != meta_end)
                return fail("the file meta group ends at byte %zu, its group length (0002,0000) says %zu", pos,
                            meta_end);
            in_meta = false;
        }
        if (meta && pos == 132) { // PS3.10 7.1: (0002,0000) UL, 4 bytes, the group's length after it
            if (u16(pos + 2, true) != 0 || b[pos + 4] != 'U' || b[pos + 5] != 'L' || u16(pos + 6, true) != 4 ||
                end - pos < 12)
                return fail("the file meta group does not open with its group length (0002,0000) UL: not a DICOM "
                            "Part 10 file");
            meta_end = pos + 12 + u32(pos + 8, true);
            if (meta_end + 8 > n)
                return fail("the file meta group's length (0002,0000) runs to byte %zu, leaving no dataset in the "
                            "%zu-byte file", meta_end, n);
        }
        const uint16_t group = meta ? 0x0002 : u16(pos, false), elem = u16(pos + 2, meta);
        if (group == 0xfffe && elem == 0xe00d && until_item_end) { // item end
            pos += 8;
            return true;
        }
        uint32_t len;
        size_t header;
        bool sq = false;
        if (meta || !implicit_vr) {
            const unsigned char *vr = b + pos + 4;
            // GDCM guesses at an unknown VR (it may read the element another
            // way than this walk does), so one is refused
            if (!known_vr(vr))
                return fail("data element (%04x,%04x) at byte %zu has VR '%c%c', not one of DICOM's (PS3.5 6.2)", group,
                            elem, pos, vr[0] >= 32 && vr[0] < 127 ? vr[0] : '?', vr[1] >= 32 && vr[1] < 127 ? vr[1] : '?');
            if (!meta && !vr_agrees(group, elem, vr))
                return fail("data element (%04x,%04x) at byte %zu has VR '%c%c', which the DICOM dictionary does not "
                            "allow for it", group, elem, pos, vr[0], vr[1]);
            if (long_length_vr(vr)) {
                if (end - pos < 12) return cut(pos);
                len = u32(pos + 8, meta);
                header = 12;
                sq = vr[0] == 'S' || vr[0] == 'U'; // SQ, or UN of undefined length (PS3.5 6.2.2)
            } else {
                len = u16(pos + 6, meta);
                header = 8;
            }
        } else {
            len = u32(pos + 4, false);
            header = 8;
            sq = true; // implicit VR: an undefined length is a sequence
        }
        const size_t at = pos;
        pos += header;
        if (meta && (len == UNDEFINED || sq))
            return fail("file meta element (0002,%04x) at byte %zu is a sequence or of undefined length", elem, at);
        if (len == UNDEFINED) {
            const bool pixels = group == 0x7fe0 && elem == 0x0010;
            if (!pixels && !sq)
                return fail("data element (%04x,%04x) at byte %zu has an undefined length, allowed only for "
                            "sequences and pixel data", group, elem, at);
            // a UN of undefined length holds its items in implicit VR (PS3.5 6.2.2)
            const bool was_implicit = implicit_vr;
            if (!pixels && !meta && !implicit_vr && b[at + 4] == 'U') implicit_vr = true;
            const bool ok = pixels ? fragments(pos) : sequence(pos, depth);
            implicit_vr = was_implicit;
            if (!ok) return false;
            continue;
        }
        if (len > end - pos) return too_long("data element", group, elem, at, len, end - pos);
        if (meta && elem == 0x0010) { // TransferSyntaxUID
            std::string ts((const char *)b + pos, len);
            while (!ts.empty() && (ts.back() == '\0' || ts.back() == ' ')) ts.pop_back();
            saw_syntax = true;
            implicit_vr = ts == "1.2.840.10008.1.2";
            big = ts == "1.2.840.10008.1.2.2";
            if (ts == "1.2.840.10008.1.2.1.99") { // deflated: the rest is a deflate stream
                pos = n;
                return true;
            }
        }
        pos += len;
    }
    if (until_item_end) return cut(pos);
    if (depth == 0 && !saw_syntax)
        return fail("no TransferSyntaxUID (0002,0010) in a file meta group (0002) opening the file: not a DICOM Part "
                    "10 file");
    return true;
}

} // namespace

bool has_part10_mark(const std::string &path)
{
    FILE *f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    char head[132];
    size_t got = std::fread(head, 1, sizeof head, f);
    std::fclose(f);
    return got == sizeof head && std::memcmp(head + 128, "DICM", 4) == 0;
}

bool lengths_fit(const std::string &path, std::string &why)
{
    int fd = open(path.c_str(), O_RDONLY);
    if (fd < 0) {
        why = "cannot open";
        return false;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || st.st_size < 132) {
        close(fd);
        why = "shorter than DICOM's 132-byte preamble and mark";
        return false;
    }
    const size_t n = (size_t)st.st_size;
    void *map = mmap(NULL, n, PROT_READ, MAP_PRIVATE, fd, 0);
    close(fd);
    if (map == MAP_FAILED) {
        why = "cannot map the file";
        return false;
    }
    Walker w;
    w.b = (const unsigned char *)map;
    w.n = n;
    size_t pos = 132;
    bool ok = w.dataset(pos, n, 0, false);
    munmap(map, n);
    if (!ok) why = w.why;
    return ok;
}

} // namespace ohm_dicom
