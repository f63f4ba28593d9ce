// How a computation ended, shared by every Summary in the core.
#pragma once

namespace robocal {

/// Says whether a computation's outputs were written and can be trusted.
enum class Termination {
  /// Finished as intended; outputs written.
  kConvergence,
  /// Stopped by a budget before its convergence test passed; outputs written, best found so far.
  kNoConvergence,
  /// Outputs written but weaker than asked (e.g. rank unclear, parameters dropped); see the message.
  kDegraded,
  /// No usable output; see the message. The initial value of every Summary.
  kFailure,
};

inline const char* ToString(Termination t) {
  switch (t) {
    case Termination::kConvergence:
      return "CONVERGENCE";
    case Termination::kNoConvergence:
      return "NO_CONVERGENCE";
    case Termination::kDegraded:
      return "DEGRADED";
    case Termination::kFailure:
      return "FAILURE";
  }
  return "?";
}

}  // namespace robocal
