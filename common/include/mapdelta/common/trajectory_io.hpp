#pragma once
// Trajectory files: TUM ("t x y z qx qy qz qw", t in seconds) and EuRoC ground-truth CSV
// ("#timestamp [ns], p_RS_R_x ..., q_RS_w, q_RS_x, q_RS_y, q_RS_z, ..."). Parse errors name
// the file and the line.
#include <string>

#include "mapdelta/common/pose.hpp"

namespace mapdelta {

enum class TrajectoryFormat { kAuto, kTum, kEuroc };

Trajectory ReadTumTrajectory(const std::string& path);
Trajectory ReadEurocTrajectory(const std::string& path);
// kAuto: a .csv file or a first data line with commas is EuRoC, otherwise TUM.
Trajectory ReadTrajectory(const std::string& path,
                          TrajectoryFormat format = TrajectoryFormat::kAuto);
void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory);

}  // namespace mapdelta
