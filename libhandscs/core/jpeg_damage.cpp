#include "core/jpeg_damage.h"

#include <algorithm>
#include <cctype>
#include <csetjmp>
#include <cstdio>
#include <cstring>

// jpeglib.h needs FILE and size_t declared first (<cstdio>).
#include <jpeglib.h>
#include <jerror.h>

#include "core/error.h"
#include "core/image_header.h"
#include "core/text.h"

namespace handscs {
namespace {

// libjpeg's error manager, extended: an error leaves the decode through longjmp (libjpeg is C:
// no C++ exception may cross it); a warning (message level -1) is counted, the first one kept.
struct ErrorManager {
  jpeg_error_mgr pub;  // first: libjpeg's pointer to it is a pointer to this
  std::jmp_buf escape;
  size_t file_size = 0;
  bool in_image_data = false;  // jpeg_read_header has returned: the first scan has begun
  int error_code = 0, warning_code = 0;
  bool truncated = false;        // the source ran out (libjpeg then supplies an end-of-image marker)
  long error_at = -1, warning_at = -1;
  char error[JMSG_LENGTH_MAX] = "", warning[JMSG_LENGTH_MAX] = "";
};

// Where libjpeg's reader stands in the file: past the bytes it has taken, or at the marker it has
// just read and not yet acted on. -1 once the source has run out.
long reader_offset(j_common_ptr common) {
  const auto* cinfo = reinterpret_cast<j_decompress_ptr>(common);
  const auto* err = reinterpret_cast<const ErrorManager*>(common->err);
  if (cinfo->src == nullptr || err->truncated) return -1;
  const long read = static_cast<long>(err->file_size - cinfo->src->bytes_in_buffer);
  return cinfo->unread_marker != 0 ? read - 2 : read;
}

void on_error(j_common_ptr common) {
  auto* err = reinterpret_cast<ErrorManager*>(common->err);
  err->error_code = err->pub.msg_code;
  err->error_at = reader_offset(common);
  (*err->pub.format_message)(common, err->error);
  std::longjmp(err->escape, 1);
}

void on_message(j_common_ptr common, int level) {
  if (level != -1) return;  // trace messages
  auto* err = reinterpret_cast<ErrorManager*>(common->err);
  // Metadata libjpeg reads past without changing a pixel: a JFIF revision it does not know (a
  // writer's, or a flip there) and a malformed ICC profile chunk are no damage to the image.
  if (err->pub.msg_code == JWRN_JFIF_MAJOR || err->pub.msg_code == JWRN_BOGUS_ICC) return;
  if (err->pub.msg_code == JWRN_JPEG_EOF) err->truncated = true;
  if (err->pub.num_warnings++ > 0) return;
  err->warning_code = err->pub.msg_code;
  err->warning_at = reader_offset(common);
  (*err->pub.format_message)(common, err->warning);
}

// libjpeg's text without its "Corrupt JPEG data: " prefix (the caller says what is corrupt),
// its first letter lower-cased (not an acronym's), with the byte when known.
std::string reword(const char* text, long at) {
  static const char kCorrupt[] = "Corrupt JPEG data: ";
  if (std::strncmp(text, kCorrupt, sizeof kCorrupt - 1) == 0) text += sizeof kCorrupt - 1;
  std::string out = text;
  if (out.size() > 1 && !std::isupper(static_cast<unsigned char>(out[1])))  // "JPEG ..." stays
    out[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(out[0])));
  if (at >= 0) out += " at byte " + std::to_string(at);
  return out;
}

// Names what a file that libjpeg finds no start-of-image marker in holds instead.
std::string describe_start(const uint8_t* bytes, size_t n) {
  static const uint8_t kPng[] = {0x89, 'P', 'N', 'G'};
  if (n >= 4 && std::equal(kPng, kPng + 4, bytes)) return "not a JPEG file (PNG data)";
  if (n >= 2 && bytes[0] == 'B' && bytes[1] == 'M') return "not a JPEG file (BMP data)";
  if (n == 0) return "empty file";
  return "not a JPEG file (no start-of-image marker)";
}

bool has_exif(j_decompress_ptr cinfo) {
  for (jpeg_saved_marker_ptr m = cinfo->marker_list; m != nullptr; m = m->next)
    if (m->marker == JPEG_APP0 + 1 && m->data_length >= 6 && std::memcmp(m->data, "Exif\0\0", 6) == 0) return true;
  return false;
}

// Decodes at 1/8 scale, into `thumbnail` when given and the file suits it (else as grey, which
// spares the colour conversion). Only plain data lives in this frame: longjmp skips no destructor.
void decode(const uint8_t* bytes, size_t n, ErrorManager& err, JpegThumbnail* thumbnail) {
  jpeg_decompress_struct cinfo;
  cinfo.err = jpeg_std_error(&err.pub);
  err.pub.error_exit = on_error;
  err.pub.emit_message = on_message;
  err.file_size = n;
  jpeg_create_decompress(&cinfo);
  if (setjmp(err.escape) == 0) {
    jpeg_mem_src(&cinfo, bytes, static_cast<unsigned long>(n));
    if (thumbnail) jpeg_save_markers(&cinfo, JPEG_APP0 + 1, 0xFFFF);
    jpeg_read_header(&cinfo, TRUE);
    err.in_image_data = true;
    cinfo.scale_num = 1;
    cinfo.scale_denom = 8;
    const bool wanted = thumbnail && (cinfo.num_components == 1 || cinfo.num_components == 3) && !has_exif(&cinfo);
    cinfo.out_color_space = wanted ? JCS_EXT_BGR : JCS_GRAYSCALE;
    if (cinfo.num_components == 4) cinfo.out_color_space = JCS_CMYK;  // no conversion to grey from CMYK/YCCK
    jpeg_start_decompress(&cinfo);
    const size_t row_bytes = static_cast<size_t>(cinfo.output_width) * cinfo.output_components;
    JSAMPARRAY row = (*cinfo.mem->alloc_sarray)(reinterpret_cast<j_common_ptr>(&cinfo), JPOOL_IMAGE,
                                                static_cast<JDIMENSION>(row_bytes), 1);
    if (wanted) {
      thumbnail->width = static_cast<int>(cinfo.output_width);
      thumbnail->height = static_cast<int>(cinfo.output_height);
      thumbnail->bgr.resize(row_bytes * cinfo.output_height);
    }
    while (cinfo.output_scanline < cinfo.output_height) {
      const size_t y = cinfo.output_scanline;
      jpeg_read_scanlines(&cinfo, row, 1);
      if (wanted) std::memcpy(thumbnail->bgr.data() + y * row_bytes, row[0], row_bytes);
    }
    // Reads on to the end-of-image marker: bytes left after the last scan are a warning.
    jpeg_finish_decompress(&cinfo);
  }
  jpeg_destroy_decompress(&cinfo);
}

}  // namespace

std::string jpeg_damage(const std::string& file_bytes, JpegThumbnail* thumbnail) {
  const auto* bytes = reinterpret_cast<const uint8_t*>(file_bytes.data());
  const size_t n = file_bytes.size();
  if (thumbnail) *thumbnail = JpegThumbnail{};
  ErrorManager err;
  decode(bytes, n, err, thumbnail);
  if (err.error_code == 0 && err.pub.num_warnings == 0) return "";
  if (thumbnail) *thumbnail = JpegThumbnail{};
  if (err.error_code == JERR_NO_SOI || err.error_code == JERR_INPUT_EMPTY) return describe_start(bytes, n);
  // After a cut, what libjpeg says next is about the end-of-image marker it supplied: name the cut.
  if (err.truncated)
    return err.in_image_data ? "truncated: the image data ends without an end-of-image marker"
                             : "truncated: the file ends inside its headers";
  if (err.error_code != 0) return "corrupt: " + reword(err.error, err.error_at);
  const char* kind = err.warning_code == JWRN_HIT_MARKER ? "truncated image data: " : "corrupt image data: ";
  return kind + reword(err.warning, err.warning_at);
}

bool has_jpeg_extension(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".jpg" || ext == ".jpeg";
}

std::string read_image_file(const std::string& path, std::string& jpeg_problem, JpegThumbnail* thumbnail) {
  std::string bytes = read_image_bytes(path);
  if (thumbnail) *thumbnail = JpegThumbnail{};
  jpeg_problem = has_jpeg_extension(path) ? jpeg_damage(bytes, thumbnail) : "";
  return bytes;
}

}  // namespace handscs
