// Every setting of a render, declared once: its name (the <integrator
// type="spm"> property, the settings line's and the profile's key), its
// command-line flag, its type and range, its default or how it is derived,
// its help and where its default was measured. The loader, the command
// line and its --help, the settings line printed before the first pass,
// the profile JSON and docs/TUNING.md (`spm settings`, render/tuning.h;
// checked by the tests) all come from this table. The constants that are
// not settings are render/tuning.h's table.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/integrator_options.h"
#include "scene/scene.h"

namespace spm {

namespace xml {
class Props;
}

struct Setting {
  using Member = std::variant<int IntegratorSettings::*, float IntegratorSettings::*, bool IntegratorSettings::*,
                              std::string IntegratorSettings::*>;
  const char* name;  // property and key
  const char* flag;  // command-line flag; a boolean's also as --no-...
  Member member;
  // Numbers: the values given ones may take, lo .. hi (either end excluded
  // when open), and `special`, one more outside them (-1: unlimited).
  double lo = 0.0, hi = 0.0;
  bool lo_open = false, hi_open = false;
  std::optional<double> special;
  const NamedCodes* names = nullptr;  // names: the values allowed
  // What a value left out means when the struct's default (0, -1) stands
  // for something other than itself: "derived: ...", "unlimited", ...;
  // nullptr: the default value is the value.
  std::string (*unset)() = nullptr;
  const char* help = "";
  const char* measured = nullptr;  // where the default was measured (docs/experiments/...)
  bool xml = true;                 // a property of the scene's integrator too
};

// The settings, in the order the settings line and --help give them.
const std::vector<Setting>& settings_table();

// The row named `name`; throws std::logic_error for another name.
const Setting& setting(const std::string& name);

// "" when `value` is one `s` may take, else the problem ("must be
// positive", "must be in 1 .. 65535", "unknown estimator 'x' (bre, ...)").
std::string setting_problem(const Setting& s, double value);
std::string setting_problem(const Setting& s, const std::string& value);

// Reads every setting the integrator element gives into `in`, checked,
// marking its source Scene; a bad value fails naming the element's line.
void read_settings(xml::Props& p, IntegratorSettings& in);
// The same for one setting of the table.
void read_setting(xml::Props& p, const Setting& s, IntegratorSettings& in);


// Sets `s` of `in` from the command line's text `value` (a boolean's:
// "true" or "false"), marking its source CommandLine; throws InputError
// naming the flag for a value that is not a number of the right kind or
// out of range.
void set_from_flag(const Setting& s, const std::string& value, IntegratorSettings& in);

// Throws InputError (at `where`, else `path`) for the first setting of `in`
// out of its range: values set by code rather than read, or left at their
// defaults (0: derived).
void check_settings(const IntegratorSettings& in, const std::string& path);

// The value as the settings line and the profile show it.
std::string setting_text(const Setting& s, const IntegratorSettings& in);
nlohmann::json setting_json(const Setting& s, const IntegratorSettings& in);

// "name value (source), ..." over the table for `used` (derived values
// filled in), the sources as `used.sources` records them.
std::string settings_line(const IntegratorSettings& used);
nlohmann::json settings_json(const IntegratorSettings& used);

// The help of a setting's flag: its help, then its default or derivation.
std::string setting_help(const Setting& s);

// Its default or derivation alone: "10000", "derived: ...".
std::string setting_default(const Setting& s);

}  // namespace spm
