#include "actors/envs/image_io.h"

#include <csetjmp>
#include <cstdio>
#include <memory>

#include <gif_lib.h>
#include <png.h>

namespace coins::envs {

Status WritePng(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0 || image.rgb.size() != static_cast<size_t>(image.width) * image.height * 3)
    return Errorf("png {}: bad image size {}x{}", path, image.width, image.height);
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) return Errorf("png {}: cannot open for writing", path);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    return Errorf("png {}: libpng could not start", path);
  }
  // libpng reports errors by longjmp; nothing with a destructor is created past this point
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return Errorf("png {}: libpng failed while writing", path);
  }
  png_init_io(png, f.get());
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y)
    png_write_row(png, const_cast<png_bytep>(image.rgb.data() + static_cast<size_t>(y) * image.width * 3));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return Status::Ok();
}

Status WriteGif(const std::string& path, const std::vector<Image>& frames, int delay_cs) {
  if (frames.empty()) return Errorf("gif {}: no frames", path);
  const int w = frames[0].width, h = frames[0].height;
  int err = 0;
  GifFileType* gif = EGifOpenFileName(path.c_str(), false, &err);
  if (!gif) return Errorf("gif {}: cannot open for writing ({})", path, GifErrorString(err));
  auto fail = [&](const char* what) {
    const int code = gif->Error;
    EGifCloseFile(gif, &err);
    return Errorf("gif {}: {} failed ({})", path, what, GifErrorString(code));
  };
  EGifSetGifVersion(gif, true);
  if (EGifPutScreenDesc(gif, w, h, 8, 0, nullptr) == GIF_ERROR) return fail("screen descriptor");
  // netscape loop extension: loop forever
  const unsigned char app[] = {'N', 'E', 'T', 'S', 'C', 'A', 'P', 'E', '2', '.', '0'};
  const unsigned char loop[] = {1, 0, 0};
  if (EGifPutExtensionLeader(gif, APPLICATION_EXT_FUNC_CODE) == GIF_ERROR ||
      EGifPutExtensionBlock(gif, sizeof(app), app) == GIF_ERROR ||
      EGifPutExtensionBlock(gif, sizeof(loop), loop) == GIF_ERROR || EGifPutExtensionTrailer(gif) == GIF_ERROR)
    return fail("loop extension");
  const size_t n = static_cast<size_t>(w) * h;
  std::vector<GifByteType> r(n), g(n), b(n), idx(n);
  for (const Image& frame : frames) {
    if (frame.width != w || frame.height != h || frame.rgb.size() != n * 3) return fail("frame size check");
    for (size_t i = 0; i < n; ++i) {
      r[i] = frame.rgb[3 * i];
      g[i] = frame.rgb[3 * i + 1];
      b[i] = frame.rgb[3 * i + 2];
    }
    // a 256-colour palette for this frame
    int colors = 256;
    ColorMapObject* map = GifMakeMapObject(256, nullptr);
    if (!map) return fail("colour map");
    if (GifQuantizeBuffer(w, h, &colors, r.data(), g.data(), b.data(), idx.data(), map->Colors) == GIF_ERROR) {
      GifFreeMapObject(map);
      return fail("quantise");
    }
    const unsigned char gce[] = {0x04, static_cast<unsigned char>(delay_cs & 0xff),
                                 static_cast<unsigned char>((delay_cs >> 8) & 0xff), 0};
    bool ok = EGifPutExtension(gif, GRAPHICS_EXT_FUNC_CODE, sizeof(gce), gce) != GIF_ERROR &&
              EGifPutImageDesc(gif, 0, 0, w, h, false, map) != GIF_ERROR;
    for (int y = 0; ok && y < h; ++y) ok = EGifPutLine(gif, idx.data() + static_cast<size_t>(y) * w, w) != GIF_ERROR;
    GifFreeMapObject(map);
    if (!ok) return fail("frame");
  }
  if (EGifCloseFile(gif, &err) == GIF_ERROR) return Errorf("gif {}: close failed ({})", path, GifErrorString(err));
  return Status::Ok();
}

}  // namespace coins::envs
