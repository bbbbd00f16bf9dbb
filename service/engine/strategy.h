#pragma once
/// A grasp strategy's room: everything the service knows of one strategy in one place (its
/// folder service/engine/strategies/): its name and what it needs, its options struct and the
/// table of its request fields (name, unit, default, range, a line of documentation: the one
/// table the request parser, /v1/info's defaults, openapi.yaml's check and the page's form all
/// read), the validation of its options, its planner call and the JSON of what it adds to an
/// answer. The engine and the REST handler dispatch on the registered rooms (AllStrategies())
/// without knowing any strategy's name; adding one is its room plus a line in registry.cpp.

#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "service/core/status.h"
#include "service/engine/plan.h"

namespace softgrasp::engine {

/// What a registered strategy is called and what it needs.
struct StrategyInfo {
  const char* name;               ///< as requests name it
  const char* summary;            ///< one line: what it does (the page, /v1/info)
  bool needs_stiffness_model;     ///< plans on the stiffness model's map
  bool needs_segmentation_model;  ///< plans on instances and the deformability map
  bool needs_gqcnn_model;         ///< ranks its candidates with the GQ-CNN
  /// Chooses and plans its own target (a requested target is its input); for the others a
  /// target restricts contacts to that instance and every other object stays an obstacle.
  bool plans_target;
  /// Keeps its contacts on the surfaces that stand free of the image border itself, by FGE's
  /// search on the scene's contact mask (contact_region.h); the others get the whole contact
  /// region as their scene's mask and have their grasps checked against it.
  bool finds_free_surfaces;
};

/// A field's value: a number (kNumber, kInteger), a choice's index (kChoice) or numbers
/// (kNumberList).
using FieldValue = std::variant<double, std::vector<double>>;

/// One request field of a strategy.
struct StrategyField {
  enum class Kind { kNumber, kInteger, kChoice, kNumberList };
  std::string name;  ///< as requests name it, e.g. "slice_step_mm"
  Kind kind = Kind::kNumber;
  std::string unit;  ///< "mm", "px", ... ("" for none)
  /// Numbers and integers: the allowed range; lists: each element's, the lower end excluded
  /// when min_exclusive.
  double min = 0, max = 0;
  bool min_exclusive = false;
  std::vector<std::string> choices;  ///< kChoice: the names, in index order
  int max_count = 0;                 ///< kNumberList: at most this many, strictly increasing
  std::string doc;                   ///< one line for openapi.yaml and the page
  /// Writes a parsed, in-range value into the room's options (of its own type).
  std::function<void(StrategyOptions&, const FieldValue&)> set;
  /// The value in the room's options (the defaults when given DefaultOptions()).
  std::function<FieldValue(const StrategyOptions&)> get;
};

/// A strategy's room. Rooms are stateless; one instance each lives for the process.
class Strategy {
 public:
  virtual ~Strategy() = default;

  virtual const StrategyInfo& info() const = 0;
  /// Its request fields (none for a strategy without options of its own).
  virtual const std::vector<StrategyField>& fields() const;
  /// A fresh copy of its default options; null for a strategy without options of its own.
  virtual std::shared_ptr<StrategyOptions> DefaultOptions() const { return nullptr; }
  /// Why it cannot plan with `options` (its room's type, or null for the defaults) and the
  /// common ones (kInvalidArgument naming the request field); nullopt when it can. The engine
  /// calls it before planning: planners throw on what this refuses.
  virtual std::optional<core::Error> Validate(const StrategyOptions* options,
                                              const PlanOptions& common,
                                              const core::Camera& camera) const;
  /// Plans on `context` into `plan->grasps` (best first) and, when it has any, its details.
  virtual std::optional<core::Error> Plan(const PlanContext& context,
                                          const StrategyOptions* options,
                                          engine::Plan* plan) const = 0;

  /// The key under which every grasp of an answer carries this strategy's details (null for
  /// the grasps of other strategies); empty when it adds none to its grasps.
  virtual const char* grasp_details_key() const { return ""; }
  /// That object for one of its grasps.
  virtual nlohmann::json GraspDetailsJson(const PlannedGrasp& /*grasp*/) const { return nullptr; }
  /// Adds what it knows of the whole plan to the answer's body (e.g. its own statistics).
  virtual void WritePlanJson(const engine::Plan& /*plan*/, nlohmann::json* /*body*/) const {}
};

/// Every registered room, in order of preference: the default strategy is the last one the
/// loaded models serve (registry.cpp).
const std::vector<const Strategy*>& AllStrategies();

/// Builders of field table rows for a room whose options are of type O. `ref` is a generic
/// lambda returning a reference to the member, e.g. [](auto& o) -> auto& { return o.seed; },
/// called on O& to write and on const O& to read. A number that requests give in `scale` units
/// of the member (slice_step_mm of slice_step_m: 1000) is read as member = value / scale and
/// shown as member * scale.
template <class O>
struct FieldsOf {
  template <class Ref>
  static StrategyField Number(std::string name, std::string unit, double min, double max,
                              std::string doc, Ref ref, double scale = 1.0, bool integer = false) {
    using T = std::remove_cvref_t<decltype(ref(std::declval<O&>()))>;
    StrategyField f;
    f.name = std::move(name);
    f.kind = integer ? StrategyField::Kind::kInteger : StrategyField::Kind::kNumber;
    f.unit = std::move(unit);
    f.min = min;
    f.max = max;
    f.doc = std::move(doc);
    f.set = [ref, scale](StrategyOptions& o, const FieldValue& v) {
      const double value = std::get<double>(v);
      ref(static_cast<O&>(o)) = static_cast<T>(scale == 1.0 ? value : value / scale);
    };
    f.get = [ref, scale](const StrategyOptions& o) -> FieldValue {
      const auto value = static_cast<double>(ref(static_cast<const O&>(o)));
      return scale == 1.0 ? value : value * scale;
    };
    return f;
  }
  template <class Ref>
  static StrategyField Integer(std::string name, std::string unit, double min, double max,
                               std::string doc, Ref ref) {
    return Number(std::move(name), std::move(unit), min, max, std::move(doc), ref, 1.0, true);
  }
  /// An enum member whose values are 0, 1, ... in the order of `choices`.
  template <class Ref>
  static StrategyField Choice(std::string name, std::vector<std::string> choices, std::string doc,
                              Ref ref) {
    using E = std::remove_cvref_t<decltype(ref(std::declval<O&>()))>;
    StrategyField f;
    f.name = std::move(name);
    f.kind = StrategyField::Kind::kChoice;
    f.choices = std::move(choices);
    f.doc = std::move(doc);
    f.set = [ref](StrategyOptions& o, const FieldValue& v) {
      ref(static_cast<O&>(o)) = static_cast<E>(static_cast<int>(std::get<double>(v)));
    };
    f.get = [ref](const StrategyOptions& o) -> FieldValue {
      return static_cast<double>(static_cast<int>(ref(static_cast<const O&>(o))));
    };
    return f;
  }
  template <class Ref>
  static StrategyField NumberList(std::string name, std::string unit, double min, double max,
                                  bool min_exclusive, int max_count, std::string doc, Ref ref) {
    StrategyField f;
    f.name = std::move(name);
    f.kind = StrategyField::Kind::kNumberList;
    f.unit = std::move(unit);
    f.min = min;
    f.max = max;
    f.min_exclusive = min_exclusive;
    f.max_count = max_count;
    f.doc = std::move(doc);
    f.set = [ref](StrategyOptions& o, const FieldValue& v) {
      ref(static_cast<O&>(o)) = std::get<std::vector<double>>(v);
    };
    f.get = [ref](const StrategyOptions& o) -> FieldValue { return ref(static_cast<const O&>(o)); };
    return f;
  }
};

/// The room's options as its own type: `options` when given, else its defaults.
template <class O>
const O& OptionsOr(const StrategyOptions* options) {
  static const O defaults{};
  return options ? static_cast<const O&>(*options) : defaults;
}

/// A field's value as JSON: a number, a choice's name, or an array of numbers.
nlohmann::json FieldValueJson(const StrategyField& field, const FieldValue& value);

}  // namespace softgrasp::engine
