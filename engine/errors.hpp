#pragma once
// Typed errors: bad input names file, line and problem; non-convergence names step, iterations
// and residual. The app turns both into a message and a non-zero exit.
#include <stdexcept>
#include <string>

namespace vimd {

class InputError : public std::runtime_error {
 public:
  InputError(std::string file, int line, const std::string& problem)
      : std::runtime_error(location(file, line) + problem), file_(std::move(file)), line_(line) {}
  const std::string& file() const { return file_; }
  int line() const { return line_; }  // 0 when the problem is not tied to one line

 private:
  static std::string location(const std::string& file, int line) {
    std::string where = file;
    if (line > 0) where.append(":").append(std::to_string(line));
    return where.append(": ");
  }
  std::string file_;
  int line_;
};

class ConvergenceError : public std::runtime_error {
 public:
  ConvergenceError(const std::string& solver, long step, int iterations, double residual, const std::string& detail = "")
      : std::runtime_error(solver + " did not converge at step " + std::to_string(step) + " after " +
                           std::to_string(iterations) + " iterations (residual " + format_residual(residual) + ")" +
                           (detail.empty() ? std::string() : ": " + detail)),
        step_(step),
        iterations_(iterations),
        residual_(residual) {}
  long step() const { return step_; }
  int iterations() const { return iterations_; }
  double residual() const { return residual_; }

 protected:
  // A run that cannot go on for another reason than a solver (see BlowUpError): the message as is.
  ConvergenceError(const std::string& message, long step)
      : std::runtime_error(message), step_(step), iterations_(0), residual_(0) {}

 private:
  static std::string format_residual(double r) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3e", r);
    return buf;
  }
  long step_;
  int iterations_;
  double residual_;
};

}  // namespace vimd
