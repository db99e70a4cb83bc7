#include "denoise/denoiser.h"
#include "render/film.h"

namespace pt {

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
