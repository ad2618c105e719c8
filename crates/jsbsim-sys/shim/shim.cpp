// A thin extern "C" layer over JSBSim::FGFDMExec for aeroid.
//
// Every function catches every C++ exception and reports it as a non-zero
// status; the message is then available from aeroid_jsb_last_error() on the
// same thread. JSBSim's log records of level WARN and above are captured in a
// thread-local buffer (JSBSim's logger is thread-local too) and appended to
// the error message, so a failed load names the file that JSBSim rejected.
// Lower levels are discarded, which keeps the console quiet.

#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "FGFDMExec.h"
#include "input_output/FGLog.h"
#include "input_output/FGPropertyManager.h"
#include "input_output/FGXMLElement.h"
#include "models/FGInput.h"
#include "models/FGOutput.h"
#include "input_output/FGOutputType.h"
#include "simgear/misc/sg_path.hxx"

using namespace JSBSim;

namespace {

thread_local std::string last_error;
thread_local std::string captured_log;

class CapturingLogger : public FGLogger {
public:
  void SetLevel(LogLevel level) override {
    log_level = level;
    record.clear();
  }
  void FileLocation(const std::string& filename, int line) override {
    record += "in file " + filename + ", line " + std::to_string(line) + ": ";
  }
  void Message(const std::string& message) override { record += message; }
  void Flush(void) override {
    if (log_level >= LogLevel::WARN && log_level != LogLevel::STDOUT) {
      // Collapse JSBSim's layout (leading newlines, indentation) to one line.
      std::string line;
      bool space = false;
      for (char c : record) {
        if (c == '\n' || c == '\r' || c == '\t' || c == ' ') {
          space = !line.empty();
        } else {
          if (space) line += ' ';
          space = false;
          line += c;
        }
      }
      if (!line.empty()) {
        if (!captured_log.empty()) captured_log += "; ";
        captured_log += line;
      }
    }
    record.clear();
  }

private:
  std::string record;
};

void install_logger() {
  thread_local bool installed = false;
  if (!installed) {
    SetLogger(std::make_shared<CapturingLogger>());
    installed = true;
  }
}

int fail(const std::string& what) {
  last_error = what;
  if (!captured_log.empty()) {
    last_error += " (JSBSim: " + captured_log + ")";
    captured_log.clear();
  }
  return 1;
}

// Runs `body`, turning any C++ exception into status 1 and a message.
template <typename F>
int guarded(const char* operation, F&& body) {
  try {
    install_logger();
    captured_log.clear();
    return body();
  } catch (const std::exception& e) {
    return fail(std::string(operation) + ": " + e.what());
  } catch (const std::string& s) {
    return fail(std::string(operation) + ": " + s);
  } catch (const char* s) {
    return fail(std::string(operation) + ": " + s);
  } catch (...) {
    return fail(std::string(operation) + ": unknown C++ exception");
  }
}

// FGOutput keeps its output instances in a private vector. An aircraft file's
// <output> elements create CSV files and sockets in RunIC even when output is
// disabled, so after loading, the shim moves those instances out of FGOutput
// (they are then never initialised or run) and deletes them after the
// executive. The explicit instantiation below is the standard-conforming way
// to name a private member.
struct OutputTypesTag {
  using type = std::vector<FGOutputType*> FGOutput::*;
  friend type get(OutputTypesTag);
};
template <typename Tag, typename Tag::type Member>
struct Expose {
  friend typename Tag::type get(Tag) { return Member; }
};
template struct Expose<OutputTypesTag, &FGOutput::OutputTypes>;

std::once_flag warm_flag;

}  // namespace

struct aeroid_jsb {
  std::unique_ptr<FGFDMExec> exec;
  std::vector<FGOutputType*> detached_outputs;
  ~aeroid_jsb() {
    exec.reset();
    for (auto* output : detached_outputs) delete output;
  }
};

extern "C" {

const char* aeroid_jsb_last_error(void) { return last_error.c_str(); }

// Warms JSBSim's process-wide state once: the static unit-conversion table of
// Element (filled, unguarded, by the first Element ever constructed, so
// threads loading their first models at the same time race on it) and the
// static debug level (0: no console chatter, unless JSBSIM_DEBUG is set).
int aeroid_jsb_warm(void) {
  return guarded("warm up", [] {
    std::call_once(warm_flag, [] {
      Element warm("aeroid-warm-up");
      if (std::getenv("JSBSIM_DEBUG") == nullptr) FGJSBBase::debug_lvl = 0;
    });
    return 0;
  });
}

int aeroid_jsb_new(const char* root_dir, aeroid_jsb** out) {
  *out = nullptr;
  if (aeroid_jsb_warm() != 0) return 1;
  return guarded("create FGFDMExec", [&] {
    auto handle = std::make_unique<aeroid_jsb>();
    handle->exec = std::make_unique<FGFDMExec>();
    handle->exec->SetRootDir(SGPath::fromLocal8Bit(root_dir));
    handle->exec->SetAircraftPath(SGPath("aircraft"));
    handle->exec->SetEnginePath(SGPath("engine"));
    handle->exec->SetSystemsPath(SGPath("systems"));
    *out = handle.release();
    return 0;
  });
}

void aeroid_jsb_delete(aeroid_jsb* h) {
  try {
    delete h;
  } catch (...) {
  }
}

int aeroid_jsb_load_model(aeroid_jsb* h, const char* aircraft_dir, const char* engine_dir,
                          const char* systems_dir, const char* model, int allow_io) {
  return guarded("load model", [&] {
    FGFDMExec& exec = *h->exec;
    if (!allow_io) {
      exec.GetInput()->Disable();
      exec.DisableOutput();
    }
    bool ok = exec.LoadModel(SGPath::fromLocal8Bit(aircraft_dir), SGPath::fromLocal8Bit(engine_dir),
                             SGPath::fromLocal8Bit(systems_dir), std::string(model), true);
    if (!ok) return fail(std::string("JSBSim could not load aircraft '") + model + "' from " +
                         aircraft_dir);
    if (!allow_io) {
      auto& outputs = (*exec.GetOutput()).*get(OutputTypesTag());
      h->detached_outputs.insert(h->detached_outputs.end(), outputs.begin(), outputs.end());
      outputs.clear();
    }
    return 0;
  });
}

// Replaces the planet of a loaded model with the <planet> document in
// `planet_file` (FGFDMExec::LoadPlanet: the inertial model's radius, rotation
// and gravity; the models are re-initialised). Call it before setting the
// initial conditions.
int aeroid_jsb_load_planet(aeroid_jsb* h, const char* planet_file) {
  return guarded("load planet", [&] {
    if (!h->exec->LoadPlanet(SGPath::fromLocal8Bit(planet_file), false))
      return fail(std::string("JSBSim could not load the planet file ") + planet_file);
    return 0;
  });
}

int aeroid_jsb_has_property(aeroid_jsb* h, const char* name, int* out) {
  *out = 0;
  return guarded("look up property", [&] {
    *out = h->exec->GetPropertyManager()->HasNode(name) ? 1 : 0;
    return 0;
  });
}

int aeroid_jsb_property_node(aeroid_jsb* h, const char* name, void** out) {
  *out = nullptr;
  return guarded("look up property", [&] {
    SGPropertyNode* node = h->exec->GetPropertyManager()->GetNode(name, false);
    if (node == nullptr) return fail(std::string("no JSBSim property named '") + name + "'");
    *out = node;
    return 0;
  });
}

int aeroid_jsb_node_get(void* node, double* out) {
  return guarded("read property", [&] {
    *out = static_cast<SGPropertyNode*>(node)->getDoubleValue();
    return 0;
  });
}

int aeroid_jsb_node_set(void* node, double value) {
  return guarded("write property", [&] {
    if (!static_cast<SGPropertyNode*>(node)->setDoubleValue(value))
      return fail(std::string("JSBSim property '") +
                  static_cast<SGPropertyNode*>(node)->getPath() + "' is read-only");
    return 0;
  });
}

int aeroid_jsb_get_property(aeroid_jsb* h, const char* name, double* out) {
  void* node = nullptr;
  if (aeroid_jsb_property_node(h, name, &node) != 0) return 1;
  return aeroid_jsb_node_get(node, out);
}

int aeroid_jsb_set_property(aeroid_jsb* h, const char* name, double value) {
  void* node = nullptr;
  if (aeroid_jsb_property_node(h, name, &node) != 0) return 1;
  return aeroid_jsb_node_set(node, value);
}

int aeroid_jsb_run_ic(aeroid_jsb* h) {
  return guarded("run initial conditions", [&] {
    if (!h->exec->RunIC()) return fail("JSBSim RunIC failed");
    return 0;
  });
}

int aeroid_jsb_run(aeroid_jsb* h) {
  return guarded("step", [&] {
    if (!h->exec->Run()) return fail("JSBSim Run returned false (end of script or terminate)");
    return 0;
  });
}

int aeroid_jsb_set_dt(aeroid_jsb* h, double dt) {
  return guarded("set dt", [&] {
    h->exec->Setdt(dt);
    return 0;
  });
}

int aeroid_jsb_get_dt(aeroid_jsb* h, double* out) {
  return guarded("get dt", [&] {
    *out = h->exec->GetDeltaT();
    return 0;
  });
}

int aeroid_jsb_sim_time(aeroid_jsb* h, double* out) {
  return guarded("get time", [&] {
    *out = h->exec->GetSimTime();
    return 0;
  });
}

int aeroid_jsb_trim(aeroid_jsb* h, int mode) {
  return guarded("trim", [&] {
    h->exec->DoTrim(mode);
    return 0;
  });
}

}  // extern "C"
