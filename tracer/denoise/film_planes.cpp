#include "denoise/denoiser.h"

#include <stdexcept>

#include "render/film.h"

namespace pt {

void check_denoise_input(const DenoiseInput& in) {
  const size_t n = static_cast<size_t>(in.width) * static_cast<size_t>(in.height);
  if (in.width <= 0 || in.height <= 0) throw std::invalid_argument("denoise: empty image");
  for (const auto* p : {in.color, in.variance, in.albedo, in.normal})
    if (!p || p->size() != 3 * n) throw std::invalid_argument("denoise: a 3-channel input is missing or mis-sized");
  if (!in.depth || in.depth->size() != n) throw std::invalid_argument("denoise: depth is missing or mis-sized");
  if (in.emission && in.emission->size() != 3 * n) throw std::invalid_argument("denoise: emission is mis-sized");
}

void FilmPlanes::copy_from(const Film& film) {
  width = film.width();
  height = film.height();
  color = film.mean_image();
  variance = film.variance_image();
  albedo = film.albedo_image();
  normal = film.normal_image();
  depth = film.depth_image();
  emission = film.emission_image();
}

std::vector<float> denoise_film(const Film& film, const DenoiseSettings& settings, ThreadPool& pool) {
  FilmPlanes planes;
  planes.copy_from(film);
  return denoise(planes.input(), settings, pool);
}

std::vector<float> denoise_film(const Film& film, DenoiseMethod method, ThreadPool& pool) {
  if (method == DenoiseMethod::Atrous) return denoise_film(film, DenoiseSettings{}, pool);
  FilmPlanes planes;
  planes.copy_from(film);
  return denoise_regression(planes.input(), RegressionSettings{}, pool);
}

}  // namespace pt
