#include "io/film_exr.h"

#include "io/image_io.h"

namespace pt {

void write_film_exr(const std::string& path, const Film& film, const FilmExrOptions& options) {
  // Every plane is kept alive here until the file is encoded.
  std::vector<std::vector<float>> planes;
  planes.reserve(options.aovs.size() + 1);
  std::vector<ExrChannel> channels;
  auto add = [&](std::vector<float> plane, const std::string& layer, const char* names, size_t count) {
    planes.push_back(std::move(plane));
    for (size_t c = 0; c < count; ++c)
      channels.push_back({layer.empty() ? std::string(1, names[c]) : layer + "." + names[c], planes.back().data() + c,
                          count});
  };
  add(film.mean_image(), "", "RGB", 3);
  for (const Aov a : options.aovs) {
    if (aov_needs_features(a) && !film.has_features())
      throw ImageError(path + ": layer '" + enum_name(a) + "' needs the film's feature buffers");
    switch (a) {
      case Aov::Albedo:
        add(film.albedo_image(), "albedo", "RGB", 3);
        break;
      case Aov::Normal:
        add(film.normal_image(), "normal", "XYZ", 3);
        break;
      case Aov::Depth:
        add(film.depth_image(), "depth", "Z", 1);
        break;
      case Aov::Emission:
        add(film.emission_image(), "emission", "RGB", 3);
        break;
      case Aov::Variance:
        add(film.variance_image(), "variance", "RGB", 3);
        break;
      case Aov::Spp:
        add(film.count_image(), "spp", "Y", 1);
        break;
      case Aov::Denoised:
        if (!options.denoised || options.denoised->size() != 3 * film.pixel_count())
          throw ImageError(path + ": layer 'denoised' has no denoised image to write");
        add(*options.denoised, "denoised", "RGB", 3);
        break;
    }
  }
  write_exr_channels(path, film.width(), film.height(), channels, options.half_float);
}

}  // namespace pt
