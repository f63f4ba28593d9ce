// Reading request JSON with field paths.
#include "robocal/api/json_reader.h"

#include <cmath>
#include <set>
#include <vector>

namespace robocal::api {
namespace {

const char* TypeName(const nlohmann::json& v) { return v.type_name(); }

std::string SizeReason(std::size_t min_size, std::size_t max_size, std::size_t got) {
  if (min_size == max_size) {
    return "expected " + std::to_string(min_size) + " values, got " + std::to_string(got);
  }
  if (got < min_size) {
    return got == 0 ? "must not be empty" : "expected at least " + std::to_string(min_size) + " values, got " +
                                                 std::to_string(got);
  }
  return "too many values: " + std::to_string(got) + " (limit " + std::to_string(max_size) + ")";
}

}  // namespace

std::string JoinPath(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string IndexPath(const std::string& path, std::size_t index) {
  return path + "[" + std::to_string(index) + "]";
}

namespace {

// A first pass over request text with the parser's event interface, before any value is built: it refuses
// nesting deeper than kMaxJsonDepth (a deep body would otherwise cost hundreds of bytes per input byte) and keys
// repeated within one object (the parser alone keeps the last one silently). Linear in the body: one small frame
// per open object or array, and a path is spelt out only for a duplicate. (The parser's callback interface
// could do the same but rescans containers on every closing brace, which is quadratic.)
class RequestShapeCheck : public nlohmann::json_sax<nlohmann::json> {
 public:
  explicit RequestShapeCheck(std::size_t max_elements) : max_elements_(max_elements) {}
  bool null() override { return Value(); }
  bool boolean(bool) override { return Value(); }
  bool number_integer(number_integer_t) override { return Value(); }
  bool number_unsigned(number_unsigned_t) override { return Value(); }
  bool number_float(number_float_t, const string_t&) override { return Value(); }
  bool string(string_t&) override { return Value(); }
  bool binary(binary_t&) override { return Value(); }
  bool start_object(std::size_t) override { return Open(true); }
  bool start_array(std::size_t) override { return Open(false); }
  bool end_object() override { return Close(); }
  bool end_array() override { return Close(); }
  bool key(string_t& name) override {
    Frame& top = stack_.back();
    top.key = name;
    if (++top.count > max_elements_) return TooLarge();
    if (!top.keys.insert(name).second) duplicates_.Add(PathOf(stack_.size()), "duplicate key (each member may appear once)");
    return true;
  }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& e) override {
    error_ = e.what();
    error_id_ = e.id;
    error_position_ = position;
    return false;
  }

  /// Throws the ApiError for what the pass found, if anything.
  void ThrowIfBad() const {
    if (!too_large_.empty()) {
      throw ApiError(Status::kInvalidArgument, "request body too large in one place",
                     {{too_large_, "too many values: more than " + std::to_string(max_elements_) + " (limit " +
                                       std::to_string(max_elements_) + ", max_array_length)"}});
    }
    if (too_deep_) {
      throw ApiError(Status::kInvalidArgument, "request body nested too deeply",
                     {{"body", "objects and arrays nest at most " + std::to_string(kMaxJsonDepth) + " levels deep"}});
    }
    if (!error_.empty()) {
      // 406: a number literal beyond double range (1e999), which would otherwise become inf.
      if (error_id_ == 406) {
        throw ApiError(Status::kInvalidArgument, "number out of range: " + error_,
                       {{"body", "a number is out of the range of a double (non-finite values are not accepted)"}});
      }
      // The message quotes the bytes last read, which may be any bytes of the request: ApiError makes them safe.
      throw ApiError(Status::kInvalidArgument, "malformed JSON: " + error_,
                     {{"body", "malformed JSON at byte " + std::to_string(error_position_)}});
    }
    duplicates_.ThrowIfAny("invalid request body");
  }

 private:
  struct Frame {
    bool object;
    std::size_t count = 0;  // elements completed (arrays), members seen (objects)
    std::string key;        // the member being read (objects)
    std::set<std::string> keys;
  };
  bool Value() {
    if (!stack_.empty() && !stack_.back().object && ++stack_.back().count > max_elements_) return TooLarge();
    return true;
  }
  // An array or object with more elements than any request may hold: refused before its values are built.
  bool TooLarge() {
    too_large_ = PathOf(stack_.size() - 1);  // the container's own path: its parents' keys and indices
    if (too_large_.empty()) too_large_ = "body";
    return false;
  }
  bool Open(bool object) {
    if (stack_.size() >= kMaxJsonDepth) {
      too_deep_ = true;
      return false;
    }
    stack_.push_back(Frame{object, 0, {}, {}});
    return true;
  }
  bool Close() {
    stack_.pop_back();
    return Value();
  }
  std::string PathOf(std::size_t frames) const {
    std::string path;
    for (std::size_t i = 0; i < frames; ++i) {
      path = stack_[i].object ? JoinPath(path, stack_[i].key) : IndexPath(path, stack_[i].count);
    }
    return path;
  }

  const std::size_t max_elements_;
  std::vector<Frame> stack_;
  Problems duplicates_;
  bool too_deep_ = false;
  std::string too_large_;
  std::string error_;
  int error_id_ = 0;
  std::size_t error_position_ = 0;
};

}  // namespace

nlohmann::json ParseBody(const std::string& body, std::size_t max_elements) {
  RequestShapeCheck check(max_elements);
  nlohmann::json::sax_parse(body, &check);
  check.ThrowIfBad();
  nlohmann::json value;
  try {
    value = nlohmann::json::parse(body);
  } catch (const nlohmann::json::exception& e) {
    // The first pass has seen the same text parse cleanly.
    throw ApiError(Status::kInvalidArgument, "malformed JSON: " + std::string(e.what()), {{"body", "malformed JSON"}});
  }
  if (!value.is_object()) {
    throw ApiError(Status::kInvalidArgument, "the request body must be a JSON object",
                   {{"body", std::string("expected an object, got ") + TypeName(value)}});
  }
  return value;
}

bool ReadFiniteNumber(const nlohmann::json& value, const std::string& path, Problems* problems, double* out) {
  if (!value.is_number()) {
    problems->Add(path, std::string("expected a number, got ") + TypeName(value));
    return false;
  }
  const double v = value.get<double>();
  // JSON has no NaN or Inf, but a literal such as 1e999 overflows to inf when parsed.
  if (!std::isfinite(v)) {
    problems->Add(path, "must be a finite number (out of double range)");
    return false;
  }
  *out = v;
  return true;
}

bool ReadNumberArray(const nlohmann::json& value, const std::string& path, Problems* problems,
                     std::vector<double>* out, std::size_t min_size, std::size_t max_size) {
  if (!value.is_array()) {
    problems->Add(path, std::string("expected an array of numbers, got ") + TypeName(value));
    return false;
  }
  if (value.size() < min_size || value.size() > max_size) {
    problems->Add(path, SizeReason(min_size, max_size, value.size()));
    return false;
  }
  std::vector<double> result(value.size());
  bool ok = true;
  for (std::size_t i = 0; i < value.size(); ++i) {
    ok = ReadFiniteNumber(value[i], IndexPath(path, i), problems, &result[i]) && ok;
  }
  if (ok) *out = std::move(result);
  return ok;
}

ObjectReader::ObjectReader(const nlohmann::json& value, std::string path, Problems* problems)
    : path_(std::move(path)), problems_(problems) {
  if (value.is_object()) {
    object_ = &value;
  } else {
    problems_->Add(path_.empty() ? "body" : path_, std::string("expected an object, got ") + TypeName(value));
  }
}

bool ObjectReader::Has(const std::string& key) const { return Get(key) != nullptr; }

const nlohmann::json* ObjectReader::Get(const std::string& key) const {
  if (object_ == nullptr) return nullptr;
  auto it = object_->find(key);
  if (it == object_->end() || it->is_null()) return nullptr;
  return &*it;
}

const nlohmann::json* ObjectReader::Member(const std::string& key, bool required) {
  if (object_ == nullptr) return nullptr;
  const nlohmann::json* v = Get(key);
  if (v == nullptr && required) problems_->Add(JoinPath(path_, key), "required");
  return v;
}

bool ObjectReader::String(const std::string& key, bool required, std::string* out, std::size_t max_length) {
  const nlohmann::json* v = Member(key, required);
  if (v == nullptr) return false;
  if (!v->is_string()) {
    problems_->Add(JoinPath(path_, key), std::string("expected a string, got ") + TypeName(*v));
    return false;
  }
  const auto& s = v->get_ref<const std::string&>();
  if (s.size() > max_length) {
    problems_->Add(JoinPath(path_, key), "too long: " + std::to_string(s.size()) + " characters (limit " +
                                             std::to_string(max_length) + ")");
    return false;
  }
  *out = s;
  return true;
}

bool ObjectReader::Bool(const std::string& key, bool required, bool* out) {
  const nlohmann::json* v = Member(key, required);
  if (v == nullptr) return false;
  if (!v->is_boolean()) {
    problems_->Add(JoinPath(path_, key), std::string("expected a boolean, got ") + TypeName(*v));
    return false;
  }
  *out = v->get<bool>();
  return true;
}

bool ObjectReader::Number(const std::string& key, bool required, double* out, double min, double max) {
  const nlohmann::json* v = Member(key, required);
  if (v == nullptr) return false;
  double x = 0.0;
  if (!ReadFiniteNumber(*v, JoinPath(path_, key), problems_, &x)) return false;
  if (x < min || x > max) {
    problems_->Add(JoinPath(path_, key), "must be in [" + nlohmann::json(min).dump() + ", " +
                                             nlohmann::json(max).dump() + "], got " + nlohmann::json(x).dump());
    return false;
  }
  *out = x;
  return true;
}

bool ObjectReader::Int(const std::string& key, bool required, std::int64_t* out, std::int64_t min,
                       std::int64_t max) {
  const nlohmann::json* v = Member(key, required);
  if (v == nullptr) return false;
  std::int64_t x = 0;
  if (v->is_number_integer()) {
    if (v->is_number_unsigned() && v->get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)) {
      problems_->Add(JoinPath(path_, key), "integer out of range");
      return false;
    }
    x = v->get<std::int64_t>();
  } else {
    problems_->Add(JoinPath(path_, key), std::string("expected an integer, got ") +
                                             (v->is_number_float() ? "a number with a fraction or exponent"
                                                                   : TypeName(*v)));
    return false;
  }
  if (x < min || x > max) {
    problems_->Add(JoinPath(path_, key), "must be in [" + std::to_string(min) + ", " + std::to_string(max) +
                                             "], got " + std::to_string(x));
    return false;
  }
  *out = x;
  return true;
}

bool ObjectReader::Int(const std::string& key, bool required, int* out, int min, int max) {
  std::int64_t x = 0;
  if (!Int(key, required, &x, min, max)) return false;
  *out = static_cast<int>(x);
  return true;
}

bool ObjectReader::Enum(const std::string& key, bool required, const std::vector<std::string>& allowed,
                        std::string* out) {
  std::string s;
  if (!String(key, required, &s)) return false;
  for (const std::string& a : allowed) {
    if (a == s) {
      *out = s;
      return true;
    }
  }
  std::string list;
  for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
  problems_->Add(JoinPath(path_, key), "unknown value \"" + s + "\" (expected one of " + list + ")");
  return false;
}

bool ObjectReader::Numbers(const std::string& key, bool required, std::vector<double>* out, std::size_t min_size,
                           std::size_t max_size) {
  const nlohmann::json* v = Member(key, required);
  if (v == nullptr) return false;
  return ReadNumberArray(*v, JoinPath(path_, key), problems_, out, min_size, max_size);
}

bool ObjectReader::FixedNumbers(const std::string& key, bool required, double* out, std::size_t size) {
  std::vector<double> values;
  if (!Numbers(key, required, &values, size, size)) return false;
  for (std::size_t i = 0; i < size; ++i) out[i] = values[i];
  return true;
}

const nlohmann::json* ObjectReader::Array(const std::string& key, bool required, std::size_t min_size,
                                          std::size_t max_size) {
  const nlohmann::json* v = Member(key, required);
  if (v == nullptr) return nullptr;
  if (!v->is_array()) {
    problems_->Add(JoinPath(path_, key), std::string("expected an array, got ") + TypeName(*v));
    return nullptr;
  }
  if (v->size() < min_size || v->size() > max_size) {
    std::string reason = v->empty() && min_size > 0
                             ? "must not be empty"
                             : (v->size() > max_size ? "too many elements: " + std::to_string(v->size()) +
                                                           " (limit " + std::to_string(max_size) + ")"
                                                     : "expected at least " + std::to_string(min_size) +
                                                           " elements, got " + std::to_string(v->size()));
    problems_->Add(JoinPath(path_, key), reason);
    return nullptr;
  }
  return v;
}

namespace detail {
bool InRange(double x, const RequestRule& rule, const std::string& path, Problems* problems) {
  if (x >= rule.min && x <= rule.max) return true;
  problems->Add(path, "must be in [" + nlohmann::json(rule.min).dump() + ", " + nlohmann::json(rule.max).dump() +
                          "], got " + nlohmann::json(x).dump());
  return false;
}
}  // namespace detail

void ObjectReader::RejectUnknown(std::initializer_list<const char*> known) {
  RejectUnknown(std::span<const char* const>(known.begin(), known.size()));
}

void ObjectReader::RejectUnknown(std::span<const char* const> known) {
  if (object_ == nullptr) return;
  for (auto it = object_->begin(); it != object_->end(); ++it) {
    bool found = false;
    for (const char* k : known) found = found || it.key() == k;
    if (!found) problems_->Add(JoinPath(path_, it.key()), "unknown field");
  }
}

}  // namespace robocal::api
