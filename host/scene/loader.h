// Loads a scene file in the Mitsuba 3 XML subset of SCENES.md.
#pragma once

#include <map>
#include <string>

#include "scene/scene.h"

namespace spm {

// `overrides` replaces <default name="..." value="..."/> values (command-line -D).
// Throws InputError("file:line", problem) for anything malformed or unsupported.
Scene load_scene(const std::string& path, const std::map<std::string, std::string>& overrides = {});

// Same, from XML text; `name` is used in messages and to resolve relative paths.
Scene load_scene_string(const std::string& xml, const std::string& name,
                        const std::map<std::string, std::string>& overrides = {});

}  // namespace spm
