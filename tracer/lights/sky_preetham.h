// Analytic daylight: the Preetham, Shirley & Smits sky ("A Practical Analytic Model for Daylight",
// SIGGRAPH 1999; equation numbers below refer to that paper) and the sun as a small bright disk.
//
// Units: radiance in units of 10⁴ cd/m² (= 10 kcd/m²): the sky's luminance Y in cd/m² divided by 10⁴, so that
// luminance(rgb) is that number. The sun's disk is 1.6·10⁵ of these units before the atmosphere. A white
// Lambertian ground under sun and sky, sun 45° up, T = 3, comes out at luminance ≈ 2.5 (1.6 of it from the sun,
// 0.9 from the sky): renders need no exposure correction.
//
// Sky, per direction ω (world, +y up) with θ = zenith angle of ω and γ = angle between ω and the sun:
//   Perez distribution (eq. 1 / Appendix A.2): F(θ, γ) = (1 + A e^{B/cos θ}) (1 + C e^{Dγ} + E cos²γ),
//   with A…E linear in the turbidity T for each of Y, x, y (Appendix A.2 tables), and
//   Y = Y_z F_Y(θ,γ)/F_Y(0,θs),  x = x_z F_x(θ,γ)/F_x(0,θs),  y = y_z F_y(θ,γ)/F_y(0,θs)   (eq. 2 / A.2),
//   zenith luminance (A.2):  χ = (4/9 − T/120)(π − 2θs),  Y_z = (4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192
//   in kcd/m², and zenith chromaticities x_z, y_z from the cubic-in-θs, quadratic-in-T matrices of A.2.
//   xyY → XYZ (X = xY/y, Z = (1 − x − y)Y/y) → linear sRGB (IEC 61966-2-1: Rec. 709 primaries, D65 white);
//   negative (out-of-gamut) components are clamped to 0.
//   Below the horizon (ω.y < 0) the sky returns black: the scene supplies the ground.
//   Sun below the horizon: the model has no twilight; the sky is evaluated with the sun's zenith angle clamped
//   to 90° (the sun kept at its azimuth, on the horizon), and the sun disk's radiance is 0.
//   Turbidity: the fit's useful range is [kMinTurbidity, kMaxTurbidity] = [1.7, 10] (below ≈1.7 the zenith
//   normalisation 1 + A_Y e^{B_Y} approaches 0 and the horizon blows up; Preetham fitted T ∈ [2, 10] or so);
//   values outside are rejected.
//
// Sun: a uniform disk of angular radius kSunHalfAngleDeg = 0.2667° around the sun direction, white
// (equal-RGB) extraterrestrial radiance kSunRadianceTopOfAtmosphere = 1.6·10⁹ cd/m², attenuated per RGB channel
// by the transmittances of Preetham's Appendix A.1 at one representative wavelength per channel (the dominant
// wavelengths of the Rec. 709 primaries, kSunWavelengthsUm = 611, 549, 464 nm):
//   Rayleigh  τ_R(λ) = exp(−0.008735 λ^−4.08 m),
//   aerosol   τ_a(λ) = exp(−β λ^−α m), Ångström β = 0.04608 T − 0.04586, α = 1.3,   (λ in µm)
//   relative optical mass m = 1/(cos θs + 0.15 (93.885 − θs[deg])^−1.253) (Kasten).
//   Ozone, water vapour and mixed-gas absorption are ignored (a few percent in the visible).
#pragma once
#include "core/math.h"
#include "io/image_io.h"

namespace pt {

inline constexpr float kMinTurbidity = 1.7f;
inline constexpr float kMaxTurbidity = 10.f;
inline constexpr float kSunHalfAngleDeg = 0.2667f;
inline constexpr double kSunRadianceTopOfAtmosphere = 1.6e9;  // cd/m²
inline constexpr double kSkyRadianceUnit = 1e4;               // cd/m² per unit of returned radiance
inline constexpr double kSunWavelengthsUm[3] = {0.611, 0.549, 0.464};

// The sun as a light: a cone of directions of half-angle `half_angle` around `dir`, uniform radiance inside.
struct SunDisk {
  Vec3 dir{0.f, 1.f, 0.f};  // unit, world, towards the sun
  float half_angle = 0.f;   // radians
  float cos_half_angle = 1.f;
  float one_minus_cos = 0.f;  // 1 − cos(half_angle), computed without cancellation (2 sin²(half/2))
  Rgb radiance{0.f};          // units of 10⁴ cd/m², after the atmosphere (0 with the sun below the horizon)
  float solid_angle() const { return 2.f * kPi * one_minus_cos; }
  // Irradiance on a surface facing the sun (radiance × solid angle).
  Rgb normal_irradiance() const { return radiance * solid_angle(); }
};

class PreethamSky {
 public:
  // sun_dir: world direction towards the sun (+y up; normalised here). Throws std::invalid_argument for a zero
  // or non-finite sun direction or a turbidity outside [kMinTurbidity, kMaxTurbidity].
  PreethamSky(Vec3 sun_dir, float turbidity);

  // Sky radiance from world direction dir (unit), no sun disk; black below the horizon.
  Rgb radiance(Vec3 dir) const;
  // Y_z of Appendix A.2 in kcd/m² (so radiance(+y) has luminance zenith_luminance_kcd()/10).
  double zenith_luminance_kcd() const { return Yz_; }
  double zenith_x() const { return xz_; }
  double zenith_y() const { return yz_; }
  Vec3 sun_direction() const { return sun_; }
  float turbidity() const { return static_cast<float>(T_); }
  SunDisk sun() const;

 private:
  struct Perez {
    double A, B, C, D, E;
    double operator()(double cos_theta, double gamma, double cos_gamma) const;
  };
  Vec3 sun_;
  double T_ = 3.0, theta_s_ = 0.0;  // theta_s_: the sun's zenith angle, clamped to ≤ π/2
  Vec3 sun_eval_;                   // sun direction used for γ (moved onto the horizon if it was below)
  Perez perez_Y_{}, perez_x_{}, perez_y_{};
  double Yz_ = 0, xz_ = 0, yz_ = 0;
  double norm_Y_ = 1, norm_x_ = 1, norm_y_ = 1;  // zenith value / F(0, θs)
};

// The sun's disk for a sun direction and turbidity (same validation as PreethamSky).
SunDisk preetham_sun(Vec3 sun_dir, float turbidity);

// Lat-long image of the sky alone (no sun disk) in EnvironmentMap's convention, each texel evaluated at its
// centre direction, in units of 10⁴ cd/m². The bottom half is black. Use it with rotation 0 (sun_dir is given
// in map space). Throws std::invalid_argument for width or height < 1, or as PreethamSky.
Image make_sky_image(Vec3 sun_dir, float turbidity, int width, int height);

}  // namespace pt
