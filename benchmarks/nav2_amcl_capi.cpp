// A C interface to Nav2's AMCL sources as the `amcl` package ships them
// (github.com/damanikjosh/amcl_python), for benchmarks/amcl_vs_nav2.py only.
//
// The package's own class always builds Nav2's beam model; this one drives the same
// particle filter (pf.c), the same differential motion model and the same update sequence
// (motion update from the odometry delta, sensor update, resampling at every call, the
// whole set's mean) with the laser model asked for: 0 beam, 1 likelihood field,
// 2 likelihood field (product). Built by the benchmark with g++ against that checkout; it is
// not part of the kit and is never imported by it.

#include <cmath>
#include <cstdlib>

#include "nav2_amcl/map/map.hpp"
#include "nav2_amcl/motion_model/differential_motion_model.hpp"
#include "nav2_amcl/pf/pf.hpp"
#include "nav2_amcl/sensors/laser/laser.hpp"

using nav2_amcl::BeamModel;
using nav2_amcl::DifferentialMotionModel;
using nav2_amcl::Laser;
using nav2_amcl::LaserData;
using nav2_amcl::LikelihoodFieldModel;
using nav2_amcl::LikelihoodFieldModelProb;

namespace {

struct Filter {
  pf_t * pf = nullptr;
  map_t * map = nullptr;
  Laser * laser = nullptr;
  DifferentialMotionModel motion;
  pf_vector_t odom{};
  pf_vector_t laser_pose{};
  bool have_odom = false;
  int model = 1;
  double z_hit = 0.5, z_short = 0.05, z_max = 0.05, z_rand = 0.5, sigma_hit = 0.2;
  double lambda_short = 0.1, max_occ_dist = 2.0;
  int max_beams = 60;
};

// No random particles are ever asked for: alpha_slow = alpha_fast = 0.
pf_vector_t no_random_pose(void *) {return pf_vector_zero();}

}  // namespace

extern "C" {

void * nav2_create(
  int min_particles, int max_particles, double alpha1, double alpha2, double alpha3,
  double alpha4, int model, double z_hit, double z_short, double z_max, double z_rand,
  double sigma_hit, double lambda_short, double max_occ_dist, int max_beams)
{
  Filter * f = new Filter();
  f->pf = pf_alloc(min_particles, max_particles, 0.0, 0.0, no_random_pose);
  f->motion.initialize(alpha1, alpha2, alpha3, alpha4, 0.0);
  f->model = model;
  f->z_hit = z_hit;
  f->z_short = z_short;
  f->z_max = z_max;
  f->z_rand = z_rand;
  f->sigma_hit = sigma_hit;
  f->lambda_short = lambda_short;
  f->max_occ_dist = max_occ_dist;
  f->max_beams = max_beams;
  return f;
}

// cells: row-major, row 0 at the origin; 0 free, 100 occupied, anything else unknown.
// (origin_x, origin_y): the lower-left corner as the package takes it.
void nav2_set_map(
  void * handle, const signed char * cells, int width, int height, double resolution,
  double origin_x, double origin_y)
{
  Filter * f = static_cast<Filter *>(handle);
  map_t * m = map_alloc();
  m->size_x = width;
  m->size_y = height;
  m->scale = resolution;
  m->origin_x = origin_x + (width / 2) * resolution;  // map_t's origin is its centre
  m->origin_y = origin_y + (height / 2) * resolution;
  m->cells = static_cast<map_cell_t *>(malloc(sizeof(map_cell_t) * width * height));
  for (int i = 0; i < width * height; i++) {
    m->cells[i].occ_state = cells[i] == 0 ? -1 : (cells[i] == 100 ? 1 : 0);
  }
  f->map = m;
  if (f->model == 0) {
    f->laser = new BeamModel(
      f->z_hit, f->z_short, f->z_max, f->z_rand, f->sigma_hit, f->lambda_short, 0.05,
      f->max_beams, m);
  } else if (f->model == 1) {
    f->laser = new LikelihoodFieldModel(
      f->z_hit, f->z_rand, f->sigma_hit, f->max_occ_dist, f->max_beams, m);
  } else {
    f->laser = new LikelihoodFieldModelProb(
      f->z_hit, f->z_rand, f->sigma_hit, f->max_occ_dist, false, 0.5, 0.3, 0.9,
      f->max_beams, m);
  }
  f->laser->SetLaserPose(f->laser_pose);
}

void nav2_set_laser_pose(void * handle, double x, double y, double yaw)
{
  Filter * f = static_cast<Filter *>(handle);
  f->laser_pose.v[0] = x;
  f->laser_pose.v[1] = y;
  f->laser_pose.v[2] = yaw;
  if (f->laser) {
    f->laser->SetLaserPose(f->laser_pose);
  }
}

void nav2_set_initial_pose(
  void * handle, double x, double y, double yaw, double var_x, double var_y, double var_yaw)
{
  Filter * f = static_cast<Filter *>(handle);
  pf_vector_t mean = pf_vector_zero();
  mean.v[0] = x;
  mean.v[1] = y;
  mean.v[2] = yaw;
  pf_matrix_t cov = pf_matrix_zero();
  cov.m[0][0] = var_x;
  cov.m[1][1] = var_y;
  cov.m[2][2] = var_yaw;
  pf_init(f->pf, mean, cov);
  f->have_odom = false;
}

// ranges[i] [m] along bearings[i] [rad, scanner frame]; odometry pose (x, y, yaw).
void nav2_update(
  void * handle, const double * ranges, const double * bearings, int count, double range_max,
  double x, double y, double yaw)
{
  Filter * f = static_cast<Filter *>(handle);
  pf_vector_t pose = pf_vector_zero();
  pose.v[0] = x;
  pose.v[1] = y;
  pose.v[2] = yaw;
  if (!f->have_odom) {
    f->odom = pose;
    f->have_odom = true;
  }
  pf_vector_t delta = pf_vector_zero();
  delta.v[0] = pose.v[0] - f->odom.v[0];
  delta.v[1] = pose.v[1] - f->odom.v[1];
  delta.v[2] = std::atan2(std::sin(pose.v[2] - f->odom.v[2]), std::cos(pose.v[2] - f->odom.v[2]));
  f->motion.odometryUpdate(f->pf, pose, delta);
  LaserData data;  // frees its ranges when it goes
  data.laser = f->laser;
  data.range_count = count;
  data.range_max = range_max;
  data.ranges = new double[count][2];
  for (int i = 0; i < count; i++) {
    data.ranges[i][0] = ranges[i];
    data.ranges[i][1] = bearings[i];
  }
  f->laser->sensorUpdate(f->pf, &data);
  pf_update_resample(f->pf, f->map);
  f->odom = pose;
}

// The whole set's mean (x, y, yaw), as the package's get_pose_mean.
void nav2_mean(void * handle, double * out)
{
  Filter * f = static_cast<Filter *>(handle);
  pf_sample_set_t * set = f->pf->sets + f->pf->current_set;
  out[0] = set->mean.v[0];
  out[1] = set->mean.v[1];
  out[2] = set->mean.v[2];
}

void nav2_free(void * handle)
{
  Filter * f = static_cast<Filter *>(handle);
  delete f->laser;
  if (f->pf) {
    pf_free(f->pf);
  }
  if (f->map) {
    map_free(f->map);
  }
  delete f;
}

}  // extern "C"
