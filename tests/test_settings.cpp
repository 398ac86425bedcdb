// The settings table (host/scene/settings.h): the command line, its --help,
// the loader, the settings line and docs/TUNING.md agree with it, and a
// value out of range exits 2 naming the flag or the file's line.
#include <gtest/gtest.h>

#include <regex>
#include <set>

#include "cli_support.h"
#include "render/tuning.h"
#include "scene/loader.h"
#include "scene/settings.h"
#include "test_support.h"

namespace {

using Settings = spm::test::CliTest;
using spm::Setting;

// A value `s` may take other than its default, as the command line and the
// file write it.
std::string valid_value(const Setting& s) {
  if (s.names) return s.names->values.back().name;
  if (std::holds_alternative<bool spm::IntegratorSettings::*>(s.member)) return "false";
  if (s.hi_open) return "0.5";
  return std::to_string(int(s.lo) + 2);
}

// One out of range: for the numbers, below the lowest value.
std::string invalid_value(const Setting& s) {
  if (s.names) return "nothing";
  int v = int(std::floor(s.lo)) - 1;
  if (s.special && *s.special == v) --v;
  return std::to_string(v);
}

bool is_bool(const Setting& s) { return std::holds_alternative<bool spm::IntegratorSettings::*>(s.member); }
bool is_int(const Setting& s) { return std::holds_alternative<int spm::IntegratorSettings::*>(s.member); }

TEST_F(Settings, HelpListsEveryFlagOnceWithItsDefault) {
  const spm::test::Outcome help = run("render --help");
  ASSERT_EQ(help.code, 0);
  std::set<std::string> names;
  for (const Setting& s : spm::settings_table()) {
    EXPECT_TRUE(names.insert(s.name).second) << "two rows named " << s.name;
    // The flag once (a boolean's --no- form too), at the start of a help line.
    const std::regex flag("\n  " + std::string(s.flag) + "[ \n]");
    EXPECT_EQ(std::distance(std::sregex_iterator(help.out.begin(), help.out.end(), flag), std::sregex_iterator()), 1)
        << s.flag;
    if (is_bool(s)) EXPECT_NE(help.out.find("--no-" + std::string(s.flag + 2)), std::string::npos) << s.flag;
    // Its default as the table derives it, not a literal of its own.
    std::string one_line = help.out;
    one_line = std::regex_replace(one_line, std::regex("\n +"), " ");
    EXPECT_NE(one_line.find("default " + spm::setting_default(s)), std::string::npos) << s.flag;
  }
}

TEST_F(Settings, TheLoaderReadsEveryPropertyAndTheFlagWins) {
  for (const Setting& s : spm::settings_table()) {
    SCOPED_TRACE(s.name);
    const std::string tag = s.names ? "string" : is_bool(s) ? "boolean" : is_int(s) ? "integer" : "float";
    const std::string xml = "<integrator type=\"spm\"><" + tag + " name=\"" + s.name + "\" value=\"" +
                            valid_value(s) + "\"/></integrator>";
    if (!s.xml) {
      EXPECT_THROW(spm::load_scene_string(spm::test::plane_scene(xml), "s.xml", {}), spm::InputError);
      continue;
    }
    spm::Scene scene = spm::load_scene_string(spm::test::plane_scene(xml), "s.xml", {});
    EXPECT_EQ(spm::setting_text(s, scene.integrator), spm::setting_text(s, [&] {
                spm::IntegratorSettings in;
                spm::set_from_flag(s, valid_value(s), in);
                return in;
              }()));
    EXPECT_EQ(scene.integrator.source(s.name), spm::SettingSource::Scene);
    EXPECT_NE(spm::setting_text(s, scene.integrator), spm::setting_text(s, spm::IntegratorSettings{}));
    spm::set_from_flag(s, valid_value(s), scene.integrator);
    EXPECT_EQ(scene.integrator.source(s.name), spm::SettingSource::CommandLine);
  }
}

TEST_F(Settings, AWrongValueExitsTwoNamingTheFlagOrTheLine) {
  const std::string scene = write("s.xml", spm::test::plane_scene());
  int checked = 0;
  for (const Setting& s : spm::settings_table()) {
    if (is_bool(s)) continue;
    SCOPED_TRACE(s.name);
    const spm::test::Outcome r = run("render " + scene + " -o " + path("o.exr") + " " + s.flag + " " +
                                     invalid_value(s));
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("spm: " + std::string(s.flag) + ": ", 0), 0u) << r.err;
    EXPECT_EQ(spm::test::count_lines(r.err), 1) << r.err;
    if (s.xml) {
      const std::string tag = s.names ? "string" : is_int(s) ? "integer" : "float";
      const std::string bad = write("bad.xml", spm::test::plane_scene("<integrator type=\"spm\">\n<" + tag +
                                                                       " name=\"" + s.name + "\" value=\"" +
                                                                       invalid_value(s) + "\"/>\n</integrator>"));
      const spm::test::Outcome f = run("render " + bad + " -o " + path("o.exr"));
      EXPECT_EQ(f.code, 2) << f.err;
      EXPECT_EQ(f.err.rfind("spm: " + bad + ":", 0), 0u) << f.err;
      EXPECT_NE(f.err.find(s.name), std::string::npos) << f.err;
    }
    ++checked;
  }
  EXPECT_GE(checked, 15);
  // Not a number at all, and a fraction for a count.
  EXPECT_EQ(run("render " + scene + " -o " + path("o.exr") + " --radius big").code, 2);
  EXPECT_EQ(run("render " + scene + " -o " + path("o.exr") + " --streams 1.5").code, 2);
}

TEST_F(Settings, TheSettingsLineGivesEveryValueAndWhereItCameFrom) {
  const std::string scene = write("s.xml", spm::test::plane_scene(
                                               "<integrator type=\"spm\"><integer name=\"max_depth\" value=\"7\"/>"
                                               "</integrator>"));
  const spm::test::Outcome r =
      run("render " + scene + " -o " + path("o.exr") + " --passes 1 --spp 1 --streams 100 --associated 2");
  ASSERT_EQ(r.code, 0) << r.err;
  for (const Setting& s : spm::settings_table()) {
    EXPECT_NE(r.err.find(std::string(s.name) + " "), std::string::npos) << s.name;
  }
  EXPECT_NE(r.err.find("max_depth 7 (scene)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("streams 100 (command line)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(derived)"), std::string::npos) << r.err;  // the radius
  EXPECT_NE(r.err.find("rr_depth 5,"), std::string::npos) << r.err;  // a default, unmarked
}

// Mitsuba's path tracers render with spm's method: their max_depth and
// rr_depth are spm's (the same image as the flags give), the settings line
// says where they came from, and what spm cannot honour exits 2.
TEST_F(Settings, MitsubasPathTracersGiveTheirDepths) {
  for (const char* type : {"volpath", "volpathmis", "path"}) {
    SCOPED_TRACE(type);
    const std::string file = write(std::string(type) + ".xml",
                                   spm::test::plane_scene("<integrator type=\"" + std::string(type) +
                                                          "\"><integer name=\"max_depth\" value=\"1\"/>"
                                                          "<integer name=\"rr_depth\" value=\"3\"/></integrator>"));
    const spm::test::Outcome a = run("render " + file + " -o " + path("a.exr") + " --passes 1 --spp 2");
    ASSERT_EQ(a.code, 0) << a.err;
    EXPECT_NE(a.err.find("max_depth 1 (scene, " + std::string(type) + ")"), std::string::npos) << a.err;
    EXPECT_NE(a.err.find("rr_depth 3 (scene, " + std::string(type) + ")"), std::string::npos) << a.err;
    EXPECT_NE(a.err.find("radius "), std::string::npos) << a.err;
    EXPECT_NE(a.err.find("(derived)"), std::string::npos) << a.err;
  }
  const std::string plain = write("plain.xml", spm::test::plane_scene());
  const spm::test::Outcome b =
      run("render " + plain + " -o " + path("b.exr") + " --passes 1 --spp 2 --max-depth 1 --rr-depth 3");
  ASSERT_EQ(b.code, 0) << b.err;
  EXPECT_EQ(spm::test::read_file(path("a.exr")), spm::test::read_file(path("b.exr")));
  // The depth matters here: max_depth 1 sees no light but the lights' own.
  ASSERT_EQ(run("render " + plain + " -o " + path("c.exr") + " --passes 1 --spp 2 --rr-depth 3").code, 0);
  EXPECT_NE(spm::test::read_file(path("b.exr")), spm::test::read_file(path("c.exr")));

  for (const std::string bad : {"<integer name=\"max_depth\" value=\"-2\"/>",
                                "<boolean name=\"hide_emitters\" value=\"true\"/>",
                                "<float name=\"radius\" value=\"1\"/>"}) {
    SCOPED_TRACE(bad);
    const std::string file =
        write("bad.xml", spm::test::plane_scene("<integrator type=\"volpath\">\n" + bad + "\n</integrator>"));
    const spm::test::Outcome r = run("render " + file + " -o " + path("o.exr"));
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("spm: " + file + ":", 0), 0u) << r.err;
    EXPECT_EQ(spm::test::count_lines(r.err), 1) << r.err;
  }
}

// docs/TUNING.md is what `spm settings` prints: the table in words, never
// edited by hand.
TEST_F(Settings, TuningMdIsTheTable) {
  const std::string file = spm::test::read_file(SPM_SOURCE_DIR "/docs/TUNING.md");
  EXPECT_EQ(file, spm::tuning_markdown()) << "regenerate it: build/spm settings > docs/TUNING.md";
  const spm::test::Outcome printed = run("settings");
  EXPECT_EQ(printed.code, 0);
  EXPECT_EQ(printed.out, file);
  for (const spm::TuningConstant& c : spm::tuning_constants()) {
    EXPECT_NE(file.find(std::string("`") + c.name + "`"), std::string::npos) << c.name;
  }
}

}  // namespace
