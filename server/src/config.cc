// Server configuration: flags, environment, config file, defaults.
#include "robocal/server/config.h"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "server/storage/storage.h"

extern char** environ;

namespace robocal::server {
namespace {

enum class Kind { kString, kInt, kBool };

struct Option {
  const char* key;  // snake_case: config file key; flag is --key-with-dashes; env ROBOCAL_KEY
  Kind kind;
  const char* help;
  std::function<void(ServerConfig&, const std::string&)> set;
};

std::int64_t ToInt(const std::string& key, const std::string& text, std::int64_t min, std::int64_t max) {
  std::size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(text, &used);
  } catch (const std::exception&) {
    throw std::invalid_argument(key + ": expected an integer, got \"" + text + "\"");
  }
  if (used != text.size()) throw std::invalid_argument(key + ": expected an integer, got \"" + text + "\"");
  if (v < min || v > max) {
    throw std::invalid_argument(key + ": must be in [" + std::to_string(min) + ", " + std::to_string(max) +
                                "], got " + text);
  }
  return v;
}

bool ToBool(const std::string& key, const std::string& text) {
  if (text == "true" || text == "1" || text == "yes" || text.empty()) return true;
  if (text == "false" || text == "0" || text == "no") return false;
  throw std::invalid_argument(key + ": expected true or false, got \"" + text + "\"");
}

std::string OneOf(const std::string& key, const std::string& text, const std::vector<std::string>& allowed) {
  for (const auto& a : allowed) {
    if (a == text) return text;
  }
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : "|") + a;
  throw std::invalid_argument(key + ": expected " + list + ", got \"" + text + "\"");
}

// The database robocal serves: a PostgreSQL URL (postgresql:// or postgres://), an SQLite file path or
// ":memory:". A URL of any other store is refused at start by its scheme, never opened as a file of that name
// (mysql://... once became a directory "mysql:" shared, silently, by every instance given the URL).
std::string CheckDb(const std::string& value) {
  if (value.empty()) {
    throw std::invalid_argument("db: must not be empty (a postgresql:// URL, an SQLite file path, or :memory:)");
  }
  if (IsPostgresUrl(value)) return value;
  const std::size_t colon = value.find("://");
  if (colon != std::string::npos) {
    const std::string scheme = value.substr(0, colon);
    // RFC 3986: a letter, then letters, digits, '+', '-' or '.'.
    const char* const kSchemeCharacters = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789+.-";
    const bool is_scheme = !scheme.empty() && std::isalpha(static_cast<unsigned char>(scheme[0])) &&
                           scheme.find_first_not_of(kSchemeCharacters) == std::string::npos;
    if (is_scheme) {
      throw std::invalid_argument("db: \"" + scheme + "://\" is not a database robocal serves (give a postgresql:// " +
                                  "URL, an SQLite file path or :memory:); the URL is not taken as a file name");
    }
  }
  return value;
}

const std::vector<Option>& Options() {
  static const std::vector<Option> options = {
      {"host", Kind::kString, "address to bind (default 127.0.0.1)",
       [](ServerConfig& c, const std::string& v) { c.host = v; }},
      {"port", Kind::kInt, "port (default 8080; 0 picks a free one)",
       [](ServerConfig& c, const std::string& v) { c.port = static_cast<int>(ToInt("port", v, 0, 65535)); }},
      {"db", Kind::kString,
       "SQLite file path (default ./var/robocal.db) or postgresql://user@host/dbname URL; other URLs are refused",
       [](ServerConfig& c, const std::string& v) { c.db = CheckDb(v); }},
      {"db_pool_size", Kind::kInt, "PostgreSQL connections this instance holds open (default 8)",
       [](ServerConfig& c, const std::string& v) {
         c.db_pool_size = static_cast<int>(ToInt("db_pool_size", v, 1, 1000));
       }},
      {"operation_lease_s", Kind::kInt,
       "lease of a running async operation; another instance fails it this long after its own stopped (default 10)",
       [](ServerConfig& c, const std::string& v) {
         c.operation_lease_s = static_cast<int>(ToInt("operation_lease_s", v, 1, 3600));
       }},
      {"tokens_file", Kind::kString, "bearer tokens, one per line, '#' comments (default: no auth)",
       [](ServerConfig& c, const std::string& v) { c.tokens_file = v; }},
      {"allow_insecure_bind", Kind::kBool, "allow a non-loopback host without tokens",
       [](ServerConfig& c, const std::string& v) { c.allow_insecure_bind = ToBool("allow_insecure_bind", v); }},
      {"tls_cert", Kind::kString, "TLS certificate (PEM); with --tls-key serves HTTPS",
       [](ServerConfig& c, const std::string& v) { c.tls_cert = v; }},
      {"tls_key", Kind::kString, "TLS private key (PEM)",
       [](ServerConfig& c, const std::string& v) { c.tls_key = v; }},
      {"log_level", Kind::kString, "trace|debug|info|warn|error (default info)",
       [](ServerConfig& c, const std::string& v) {
         c.log_level = OneOf("log_level", v, {"trace", "debug", "info", "warn", "error"});
       }},
      {"log_format", Kind::kString, "text|json (default text)",
       [](ServerConfig& c, const std::string& v) { c.log_format = OneOf("log_format", v, {"text", "json"}); }},
      {"max_body_bytes", Kind::kInt, "largest request body (default 8388608)",
       [](ServerConfig& c, const std::string& v) { c.max_body_bytes = ToInt("max_body_bytes", v, 1024, 1LL << 34); }},
      {"max_measurements_per_campaign", Kind::kInt, "measurements one campaign may hold (default 100000)",
       [](ServerConfig& c, const std::string& v) {
         c.max_measurements_per_campaign = ToInt("max_measurements_per_campaign", v, 1, 1LL << 40);
       }},
      {"max_plan_configurations", Kind::kInt, "largest plan M (default 1000)",
       [](ServerConfig& c, const std::string& v) {
         c.max_plan_configurations = static_cast<int>(ToInt("max_plan_configurations", v, 1, 1000000));
       }},
      {"max_array_length", Kind::kInt, "elements of any array in a request (default 10000)",
       [](ServerConfig& c, const std::string& v) {
         c.max_array_length = ToInt("max_array_length", v, 1, 100000000);
       }},
      {"max_plan_evaluations", Kind::kInt,
       "objective evaluations of one plan in total: restarts x k_max, exchange screening (default 1000000)",
       [](ServerConfig& c, const std::string& v) {
         c.max_plan_evaluations = ToInt("max_plan_evaluations", v, 1, 1000000000);
       }},
      {"max_plan_jacobians", Kind::kInt, "configuration Jacobians of one plan: evaluations x M (default 10000000)",
       [](ServerConfig& c, const std::string& v) {
         c.max_plan_jacobians = ToInt("max_plan_jacobians", v, 1, 1LL << 40);
       }},
      {"max_plan_candidates", Kind::kInt, "exchange candidate pool, <= 2.7 kB each (default 20000)",
       [](ServerConfig& c, const std::string& v) {
         c.max_plan_candidates = static_cast<int>(ToInt("max_plan_candidates", v, 1, 1000000));
       }},
      {"max_fit_jacobian_entries", Kind::kInt, "rows x measurements x parameters of a fit (default 2000000)",
       [](ServerConfig& c, const std::string& v) {
         c.max_fit_jacobian_entries = ToInt("max_fit_jacobian_entries", v, 1, 1LL << 40);
       }},
      {"max_running_operations", Kind::kInt, "async operations running at once (default 2)",
       [](ServerConfig& c, const std::string& v) {
         c.max_running_operations = static_cast<int>(ToInt("max_running_operations", v, 1, 64));
       }},
      {"request_timeout_s", Kind::kInt, "deadline of a synchronous request in seconds (default 60)",
       [](ServerConfig& c, const std::string& v) {
         c.request_timeout_s = static_cast<int>(ToInt("request_timeout_s", v, 1, 86400));
       }},
      {"keep_alive_timeout_s", Kind::kInt, "close an idle keep-alive connection after this many seconds (default 2)",
       [](ServerConfig& c, const std::string& v) {
         c.keep_alive_timeout_s = static_cast<int>(ToInt("keep_alive_timeout_s", v, 1, 3600));
       }},
      {"request_read_timeout_s", Kind::kInt,
       "a request's line, headers and body must all arrive within this many seconds (default 10)",
       [](ServerConfig& c, const std::string& v) {
         c.request_read_timeout_s = static_cast<int>(ToInt("request_read_timeout_s", v, 1, 3600));
       }},
      {"write_timeout_s", Kind::kInt, "the client must take a whole reply within this many seconds (default 60)",
       [](ServerConfig& c, const std::string& v) {
         c.write_timeout_s = static_cast<int>(ToInt("write_timeout_s", v, 1, 86400));
       }},
      {"max_head_bytes", Kind::kInt, "request line and headers, in bytes (default 65536)",
       [](ServerConfig& c, const std::string& v) { c.max_head_bytes = ToInt("max_head_bytes", v, 1024, 1 << 24); }},
      {"threads", Kind::kInt, "requests handled at once; more wait for a slot (default 8)",
       [](ServerConfig& c, const std::string& v) { c.threads = static_cast<int>(ToInt("threads", v, 1, 1024)); }},
      {"max_connections", Kind::kInt, "connections served at once, one thread each (default 256)",
       [](ServerConfig& c, const std::string& v) {
         c.max_connections = static_cast<int>(ToInt("max_connections", v, 1, 4096));
       }},
      {"max_queued_connections", Kind::kInt, "accepted connections waiting for a thread; beyond: 503 (default 64)",
       [](ServerConfig& c, const std::string& v) {
         c.max_queued_connections = static_cast<int>(ToInt("max_queued_connections", v, 0, 4096));
       }},
  };
  return options;
}

std::string FlagName(const std::string& key) {
  std::string f = "--" + key;
  for (char& ch : f) {
    if (ch == '_') ch = '-';
  }
  return f;
}

std::string EnvName(const std::string& key) {
  std::string e = "ROBOCAL_";
  for (char ch : key) e += static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return e;
}

void ApplyFile(const std::string& path, ServerConfig* config) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("config file " + path + ": cannot be read");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw std::invalid_argument("config file " + path + ": malformed JSON: " + e.what());
  }
  if (!j.is_object()) throw std::invalid_argument("config file " + path + ": expected a JSON object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    const Option* option = nullptr;
    for (const Option& o : Options()) {
      if (it.key() == o.key) option = &o;
    }
    if (option == nullptr) throw std::invalid_argument("config file " + path + ": unknown key \"" + it.key() + "\"");
    std::string text;
    if (it->is_string()) {
      text = it->get<std::string>();
    } else if (it->is_boolean()) {
      text = it->get<bool>() ? "true" : "false";
    } else if (it->is_number_integer()) {
      text = std::to_string(it->get<std::int64_t>());
    } else {
      throw std::invalid_argument("config file " + path + ": " + it.key() + ": unsupported value " + it->dump());
    }
    option->set(*config, text);
  }
}

}  // namespace

std::string UsageText() {
  std::ostringstream out;
  out << "usage: robocal-server [options]\n\nThe robocal calibration service (HTTP/JSON).\n\noptions:\n";
  for (const Option& o : Options()) {
    std::string flag = FlagName(o.key) + (o.kind == Kind::kBool ? "" : " VALUE");
    out << "  " << flag << std::string(flag.size() < 36 ? 36 - flag.size() : 1, ' ') << o.help << "\n";
  }
  out << "  --config FILE                       JSON config file (snake_case keys of these options)\n"
         "  --help                              this text\n"
         "  --version                           the version\n\n"
         "Precedence: flags > environment (ROBOCAL_HOST, ROBOCAL_PORT, ..., ROBOCAL_CONFIG) > config file >"
         " defaults.\n";
  return out.str();
}

ConfigResult LoadConfig(const std::vector<std::string>& args, const std::map<std::string, std::string>& env) {
  ConfigResult result;
  try {
    // Flags are collected first, so that --config is known before the file is read.
    std::vector<std::pair<const Option*, std::string>> flags;
    std::string config_file;
    if (auto it = env.find("ROBOCAL_CONFIG"); it != env.end()) config_file = it->second;
    for (std::size_t i = 0; i < args.size(); ++i) {
      std::string arg = args[i], value;
      bool has_value = false;
      if (auto eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
        value = arg.substr(eq + 1);
        arg = arg.substr(0, eq);
        has_value = true;
      }
      if (arg == "--help" || arg == "-h") {
        result.message = UsageText();
        return result;
      }
      if (arg == "--version") {
        result.message = std::string("robocal-server ") + ROBOCAL_VERSION + "\n";
        return result;
      }
      auto take_value = [&]() {
        if (has_value) return value;
        if (i + 1 >= args.size()) throw std::invalid_argument(arg + ": missing value");
        return args[++i];
      };
      if (arg == "--config") {
        config_file = take_value();
        continue;
      }
      const Option* option = nullptr;
      for (const Option& o : Options()) {
        if (arg == FlagName(o.key)) option = &o;
      }
      if (option == nullptr) throw std::invalid_argument("unknown option \"" + args[i] + "\" (see --help)");
      flags.emplace_back(option, option->kind == Kind::kBool ? (has_value ? value : "true") : take_value());
    }
    ServerConfig config;
    config.config_file = config_file;
    if (!config_file.empty()) ApplyFile(config_file, &config);
    for (const Option& o : Options()) {
      if (auto it = env.find(EnvName(o.key)); it != env.end()) {
        try {
          o.set(config, it->second);
        } catch (const std::invalid_argument& e) {
          throw std::invalid_argument(EnvName(o.key) + ": " + e.what());
        }
      }
    }
    for (const auto& [option, text] : flags) option->set(config, text);
    if (config.tls_cert.empty() != config.tls_key.empty()) {
      throw std::invalid_argument("--tls-cert and --tls-key must be given together");
    }
    result.run = true;
    result.config = config;
  } catch (const std::invalid_argument& e) {
    result.exit_code = 2;
    result.message = std::string("robocal-server: ") + e.what() + "\n";
  }
  return result;
}

std::map<std::string, std::string> RobocalEnvironment() {
  std::map<std::string, std::string> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    std::string entry(*e);
    if (entry.rfind("ROBOCAL_", 0) != 0) continue;
    auto eq = entry.find('=');
    if (eq != std::string::npos) env[entry.substr(0, eq)] = entry.substr(eq + 1);
  }
  return env;
}

bool IsLoopbackHost(const std::string& host) {
  // An address, not a name that starts like one ("127.evil.example" is a DNS name anywhere).
  if (host == "localhost") return true;
  in_addr v4{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, host.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6);
  return false;
}

std::vector<std::string> ReadTokensFile(const std::string& path, std::vector<std::string>* names) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("tokens file " + path + " cannot be read");
  std::vector<std::string> tokens;
  std::string line;
  while (std::getline(in, line)) {
    if (auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream fields(line);
    std::vector<std::string> words;
    for (std::string word; fields >> word;) words.push_back(word);
    if (words.empty()) continue;
    // "TOKEN", or "NAME TOKEN": the name the calibration history records for requests with it.
    if (words.size() > 2) {
      throw std::runtime_error("tokens file " + path + ": a line is TOKEN or NAME TOKEN, got " +
                               std::to_string(words.size()) + " words");
    }
    const std::string token = words.back();
    if (names != nullptr) names->push_back(words.size() == 2 ? words[0] : std::string());
    // Clients send tokens in a header, which the HTTP layer percent-decodes: a '%' could not be sent as it is.
    for (const char c : token) {
      if (c <= ' ' || c == '%' || static_cast<unsigned char>(c) >= 0x7F) {
        throw std::runtime_error("tokens file " + path + ": a token must be printable ASCII without spaces or '%'");
      }
    }
    // Two lines with one token would make whoever presents it both: the history could not say who did what.
    if (std::find(tokens.begin(), tokens.end(), token) != tokens.end()) {
      throw std::runtime_error("tokens file " + path + ": a token appears twice");
    }
    tokens.push_back(token);
  }
  if (tokens.empty()) throw std::runtime_error("tokens file " + path + " holds no token");
  return tokens;
}

}  // namespace robocal::server
