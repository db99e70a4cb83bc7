#include "lights/sky_preetham.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "lights/environment_map.h"

namespace pt {

namespace {

constexpr double kPiD = std::numbers::pi;

Vec3 checked_sun_direction(Vec3 sun_dir, float turbidity) {
  if (!(turbidity >= kMinTurbidity && turbidity <= kMaxTurbidity))
    throw std::invalid_argument("Preetham sky: turbidity " + std::to_string(turbidity) + " outside [" +
                                std::to_string(kMinTurbidity) + ", " + std::to_string(kMaxTurbidity) + "]");
  const float len = glm::length(sun_dir);
  if (!is_finite(sun_dir) || !(len > 0.f) || !std::isfinite(len))
    throw std::invalid_argument("Preetham sky: the sun direction must be finite and non-zero");
  return sun_dir / len;
}

// CIE XYZ → linear sRGB (IEC 61966-2-1: Rec. 709 primaries, D65 white).
Rgb xyz_to_linear_srgb(double X, double Y, double Z) {
  const double r = 3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z;
  const double g = -0.9692660 * X + 1.8760108 * Y + 0.0415560 * Z;
  const double b = 0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z;
  return {static_cast<float>(std::max(r, 0.0)), static_cast<float>(std::max(g, 0.0)),
          static_cast<float>(std::max(b, 0.0))};
}

}  // namespace

// F(θ, γ) = (1 + A e^{B/cos θ}) (1 + C e^{Dγ} + E cos²γ). At the horizon B/cos θ → −∞ (B < 0 for every
// coefficient set in the valid turbidity range), so the first factor → 1; cos θ is kept ≥ 1e-6 to avoid 0/0.
double PreethamSky::Perez::operator()(double cos_theta, double gamma, double cos_gamma) const {
  return (1.0 + A * std::exp(B / std::max(cos_theta, 1e-6))) * (1.0 + C * std::exp(D * gamma) + E * cos_gamma * cos_gamma);
}

PreethamSky::PreethamSky(Vec3 sun_dir, float turbidity) : sun_(checked_sun_direction(sun_dir, turbidity)) {
  const double T = turbidity;
  T_ = T;
  // The model is defined for the sun at or above the horizon: clamp its zenith angle to 90° (keeping azimuth).
  sun_eval_ = sun_;
  if (sun_eval_.y < 0.f) {
    const float h = std::sqrt(sun_eval_.x * sun_eval_.x + sun_eval_.z * sun_eval_.z);
    sun_eval_ = h > 0.f ? Vec3(sun_eval_.x / h, 0.f, sun_eval_.z / h) : Vec3(1.f, 0.f, 0.f);
  }
  const double ts = std::acos(std::clamp(static_cast<double>(sun_eval_.y), 0.0, 1.0));
  theta_s_ = ts;

  // Appendix A.2: distribution coefficients, linear in T.
  perez_Y_ = {0.1787 * T - 1.4630, -0.3554 * T + 0.4275, -0.0227 * T + 5.3251, 0.1206 * T - 2.5771,
              -0.0670 * T + 0.3703};
  perez_x_ = {-0.0193 * T - 0.2592, -0.0665 * T + 0.0008, -0.0004 * T + 0.2125, -0.0641 * T - 0.8989,
              -0.0033 * T + 0.0452};
  perez_y_ = {-0.0167 * T - 0.2608, -0.0950 * T + 0.0092, -0.0079 * T + 0.2102, -0.0441 * T - 1.6537,
              -0.0109 * T + 0.0529};

  // Appendix A.2: zenith luminance (kcd/m²) and chromaticities.
  const double chi = (4.0 / 9.0 - T / 120.0) * (kPiD - 2.0 * ts);
  Yz_ = (4.0453 * T - 4.9710) * std::tan(chi) - 0.2155 * T + 2.4192;
  const double t2 = ts * ts, t3 = t2 * ts, T2 = T * T;
  xz_ = (0.00166 * t3 - 0.00375 * t2 + 0.00209 * ts + 0.0) * T2 +
        (-0.02903 * t3 + 0.06377 * t2 - 0.03202 * ts + 0.00394) * T +
        (0.11693 * t3 - 0.21196 * t2 + 0.06052 * ts + 0.25886);
  yz_ = (0.00275 * t3 - 0.00610 * t2 + 0.00317 * ts + 0.0) * T2 +
        (-0.04214 * t3 + 0.08970 * t2 - 0.04153 * ts + 0.00516) * T +
        (0.15346 * t3 - 0.26756 * t2 + 0.06670 * ts + 0.26688);

  // Denominators F(0, θs): the zenith direction sees the sun at γ = θs.
  const double cs = std::cos(ts);
  norm_Y_ = Yz_ / perez_Y_(1.0, ts, cs);
  norm_x_ = xz_ / perez_x_(1.0, ts, cs);
  norm_y_ = yz_ / perez_y_(1.0, ts, cs);
}

Rgb PreethamSky::radiance(Vec3 dir) const {
  if (!(dir.y >= 0.f)) return Rgb(0.f);
  const double cos_gamma = std::clamp(static_cast<double>(glm::dot(dir, sun_eval_)), -1.0, 1.0);
  const double gamma = std::acos(cos_gamma);
  const double cos_theta = std::min(static_cast<double>(dir.y), 1.0);
  const double Y = norm_Y_ * perez_Y_(cos_theta, gamma, cos_gamma);
  const double x = norm_x_ * perez_x_(cos_theta, gamma, cos_gamma);
  const double y = norm_y_ * perez_y_(cos_theta, gamma, cos_gamma);
  if (!(Y > 0.0) || !(y > 0.0)) return Rgb(0.f);
  // kcd/m² → units of 10⁴ cd/m².
  const double Yu = Y * (1e3 / kSkyRadianceUnit);
  return xyz_to_linear_srgb(x * Yu / y, Yu, (1.0 - x - y) * Yu / y);
}

SunDisk PreethamSky::sun() const {
  SunDisk s;
  s.dir = sun_;
  const double half = static_cast<double>(kSunHalfAngleDeg) * kPiD / 180.0;
  s.half_angle = static_cast<float>(half);
  s.cos_half_angle = static_cast<float>(std::cos(half));
  s.one_minus_cos = static_cast<float>(2.0 * std::sin(0.5 * half) * std::sin(0.5 * half));
  if (!(sun_.y > 0.f)) return s;  // below (or exactly on) the horizon: hidden by the ground
  // Appendix A.1 transmittances along the sun's path, one wavelength per RGB channel.
  const double theta_deg = std::acos(std::clamp(static_cast<double>(sun_.y), 0.0, 1.0)) * 180.0 / kPiD;
  const double m = 1.0 / (std::cos(theta_deg * kPiD / 180.0) + 0.15 * std::pow(93.885 - theta_deg, -1.253));
  const double beta = 0.04608 * T_ - 0.04586, alpha = 1.3;
  const double L0 = kSunRadianceTopOfAtmosphere / kSkyRadianceUnit;
  for (int c = 0; c < 3; ++c) {
    const double lambda = kSunWavelengthsUm[c];
    const double tau_r = std::exp(-0.008735 * std::pow(lambda, -4.08) * m);
    const double tau_a = std::exp(-beta * std::pow(lambda, -alpha) * m);
    s.radiance[c] = static_cast<float>(L0 * tau_r * tau_a);
  }
  return s;
}

SunDisk preetham_sun(Vec3 sun_dir, float turbidity) { return PreethamSky(sun_dir, turbidity).sun(); }

Image make_sky_image(Vec3 sun_dir, float turbidity, int width, int height) {
  if (width < 1 || height < 1) throw std::invalid_argument("make_sky_image: width and height must be >= 1");
  if (static_cast<long long>(width) * height > kMaxHdrImagePixels)
    throw std::invalid_argument("make_sky_image: image too large");
  const PreethamSky sky(sun_dir, turbidity);
  Image img{width, height, std::vector<float>(3 * static_cast<size_t>(width) * height, 0.f)};
  for (int j = 0; j < height; ++j) {
    const float v = (static_cast<float>(j) + 0.5f) / static_cast<float>(height);
    if (v > 0.5f) break;  // rows whose centre is below the horizon stay black
    for (int i = 0; i < width; ++i) {
      const float u = (static_cast<float>(i) + 0.5f) / static_cast<float>(width);
      const Rgb L = sky.radiance(EnvironmentMap::direction_from_uv({u, v}));
      float* px = &img.rgb[3 * (static_cast<size_t>(j) * width + i)];
      px[0] = L.x;
      px[1] = L.y;
      px[2] = L.z;
    }
  }
  return img;
}

}  // namespace pt
