#pragma once
// Typed errors: bad input names file, line and problem; non-convergence names step, iterations
// and residual. The app turns both into a message and a non-zero exit.
#include <stdexcept>
#include <string>

namespace vimd {

class InputError : public std::runtime_error {
 public:
  InputError(std::string file, int line, const std::string& problem)
      : std::runtime_error(location(file, line) + problem), file_(std::move(file)), line_(line), problem_(problem) {}
  const std::string& file() const { return file_; }
  int line() const { return line_; }  // 0 when the problem is not tied to one line
  const std::string& problem() const { return problem_; }  // the message without its location

 private:
  static std::string location(const std::string& file, int line) {
    std::string where = file;
    if (line > 0) where.append(":").append(std::to_string(line));
    return where.append(": ");
  }
  std::string file_;
  int line_;
  std::string problem_;
};

// A run-file setting found wrong where a component is built from the settings (or checked against
// the system), which knows the key but not where the file gave it. RunConfig::locate turns it
// into an InputError at the key's FILE:LINE; unlocated, it names the table.
class SettingError : public InputError {
 public:
  SettingError(std::string section, std::string key, const std::string& problem)
      : InputError("[" + section + "]", 0, problem), section_(std::move(section)), key_(std::move(key)) {}
  const std::string& section() const { return section_; }
  const std::string& key() const { return key_; }

 private:
  std::string section_, key_;
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
