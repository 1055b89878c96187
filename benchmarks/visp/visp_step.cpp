// visp_step: ViSP 3.5's vpServo step on redservo's afma6-4points case, timed in batches.
//
// An OPTIONAL, SEPARATE benchmark harness. ViSP is GPL-2.0-or-later: this program only
// calls ViSP's public API (vpServo, vpFeaturePoint, vpFeatureBuilder, vpPoint, vpAfma6),
// links it as a shared library, is built on demand by benchmarks/visp/build.sh and is
// never imported, linked or needed by redservo, its tests or `make test`.
// benchmarks/bench_object_path.py --visp PATH drives it (docs/speed.md, "The public path
// against ViSP").
//
// The case (redservo.bench.cases, "afma6-4points"): the Afma6 with the CCMOP tool's eMc,
// 4 points of a 0.2 m square, vpServo::EYEINHAND_L_cVe_eJe, interaction matrix CURRENT,
// PSEUDO_INVERSE, constant gain lambda. One step, as ViSP's servoAfma6FourPoints2D*
// examples run it: eJe(q) (vpAfma6::get_eJe), task.set_eJe, each point projected from the
// same pose cMo (vpPoint::track) and turned into its feature (vpFeatureBuilder::create),
// then task.computeControlLaw() (L, J1 = L cVe eJe, its SVD pseudo-inverse, -lambda J1^+ e).
//
// Protocol (one line each, on stdin; answers on stdout):
//   setup q0..q5 cMo(16, row-major) cdMo(16) X0 Y0 Z0 .. X3 Y3 Z3 lambda eMc(16)
//                               -> "ok"
//   check                       -> "qdot 6 values", "e 8", "L 48", "J 36" (J = cVe eJe,
//                                  row-major), then "end"; %.17g
//   time B                      -> "<thread CPU ns> <wall ns>" for B steps
//   version                     -> "visp <VISP_VERSION>"
// Units: m, rad, s; features in normalized image units.
#include <cstdio>
#include <ctime>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <visp3/core/vpConfig.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpPoint.h>
#include <visp3/robot/vpAfma6.h>
#include <visp3/visual_features/vpFeatureBuilder.h>
#include <visp3/visual_features/vpFeaturePoint.h>
#include <visp3/vs/vpServo.h>

namespace {

constexpr int kPoints = 4;

struct Step {
  // The features before the task: members end in reverse order, so the task (which keeps
  // pointers to them) ends first.
  vpFeaturePoint p[kPoints], pd[kPoints];
  vpPoint point[kPoints];
  vpAfma6 robot;
  vpServo task;
  vpColVector q = vpColVector(6);  // six joints (braces would make a 1-vector)
  vpHomogeneousMatrix cMo, cdMo;
  vpMatrix eJe;
  vpColVector v;

  // Reads the set-up (protocol above); false on a malformed line.
  bool setup(std::istringstream &in) {
    double m[16];
    for (unsigned i = 0; i < 6; ++i)
      if (!(in >> q[i])) return false;
    for (vpHomogeneousMatrix *M : {&cMo, &cdMo}) {
      for (double &x : m)
        if (!(in >> x)) return false;
      for (unsigned r = 0; r < 4; ++r)
        for (unsigned c = 0; c < 4; ++c) (*M)[r][c] = m[4 * r + c];
    }
    for (vpPoint &pt : point) {
      double X, Y, Z;
      if (!(in >> X >> Y >> Z)) return false;
      pt.setWorldCoordinates(X, Y, Z);
    }
    double lambda;
    if (!(in >> lambda)) return false;
    vpHomogeneousMatrix eMc;
    for (double &x : m)
      if (!(in >> x)) return false;
    for (unsigned r = 0; r < 4; ++r)
      for (unsigned c = 0; c < 4; ++c) eMc[r][c] = m[4 * r + c];
    robot.init(vpAfma6::TOOL_CCMOP, eMc);
    task.setServo(vpServo::EYEINHAND_L_cVe_eJe);
    task.setInteractionMatrixType(vpServo::CURRENT, vpServo::PSEUDO_INVERSE);
    task.setLambda(lambda);
    vpVelocityTwistMatrix cVe;
    robot.get_cVe(cVe);
    task.set_cVe(cVe);
    for (int i = 0; i < kPoints; ++i) {
      vpPoint desired = point[i];
      desired.track(cdMo);
      vpFeatureBuilder::create(pd[i], desired);
      task.addFeature(p[i], pd[i]);
    }
    run();
    return true;
  }

  // One control step (header comment).
  void run() {
    robot.get_eJe(q, eJe);
    task.set_eJe(eJe);
    for (int i = 0; i < kPoints; ++i) {
      point[i].track(cMo);
      vpFeatureBuilder::create(p[i], point[i]);
    }
    v = task.computeControlLaw();
  }
};

long long ns(clockid_t clock) {
  timespec ts;
  clock_gettime(clock, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

void print(const char *name, const vpMatrix &M) {
  std::printf("%s", name);
  for (unsigned r = 0; r < M.getRows(); ++r)
    for (unsigned c = 0; c < M.getCols(); ++c) std::printf(" %.17g", M[r][c]);
  std::printf("\n");
}

void print(const char *name, const vpColVector &x) {
  std::printf("%s", name);
  for (unsigned i = 0; i < x.getRows(); ++i) std::printf(" %.17g", x[i]);
  std::printf("\n");
}

}  // namespace

int main() {
  Step step;
  bool ready = false;
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string cmd;
    in >> cmd;
    if (cmd == "version") {
      std::printf("visp %d.%d.%d\n", VISP_VERSION_MAJOR, VISP_VERSION_MINOR, VISP_VERSION_PATCH);
    } else if (cmd == "setup") {
      ready = step.setup(in);
      std::printf(ready ? "ok\n" : "error: malformed setup line\n");
    } else if (!ready) {
      std::printf("error: setup first\n");
    } else if (cmd == "check") {
      step.run();
      print("qdot", step.v);
      print("e", step.task.getError());
      print("L", step.task.getInteractionMatrix());
      print("J", step.task.get_cVe() * step.eJe);
      std::printf("end\n");
    } else if (cmd == "time") {
      long long batch = 0;
      if (!(in >> batch) || batch <= 0) {
        std::printf("error: time needs a positive batch size\n");
      } else {
        long long c0 = ns(CLOCK_THREAD_CPUTIME_ID), w0 = ns(CLOCK_MONOTONIC);
        for (long long k = 0; k < batch; ++k) step.run();
        long long c1 = ns(CLOCK_THREAD_CPUTIME_ID), w1 = ns(CLOCK_MONOTONIC);
        std::printf("%lld %lld\n", c1 - c0, w1 - w0);
      }
    } else {
      std::printf("error: unknown command %s\n", cmd.c_str());
    }
    std::fflush(stdout);
  }
  return 0;
}
