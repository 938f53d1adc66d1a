#include "mitsuba_loader.h"
#include "../../base/error.h"
namespace caustica {
SceneDesc load_mitsuba_scene(const std::string& path, const std::map<std::string, std::string>&) {
  throw InputError(path + ": Mitsuba XML loading is not implemented yet");
}
}  // namespace caustica
