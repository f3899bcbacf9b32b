// The skidsteer.tire plugin's contract, readable from outside the library.
//
// One table of the plugin's attributes (name, default, bounds, unit, source),
// one of the floors it knows by name, and the layout of its plugin_state.  The
// plugin validates its attributes from these tables; the Python package reads
// the same tables from the loaded library (python/skidsteer/robot/tire.py,
// through ctypes), and the attribute table of plugin/tire/README.md is
// generated from them (scripts/update_readme_tables.py; a test checks it).
// Adding an attribute is adding a row to kAttributeTable (tire_config.c) and
// reading it in tire_read_params there.

#ifndef SKIDSTEER_PLUGIN_TIRE_TIRE_CONTRACT_H_
#define SKIDSTEER_PLUGIN_TIRE_TIRE_CONTRACT_H_

#define SKIDSTEER_TIRE_EXPORT __attribute__((visibility("default")))

// Version of the structs below (bumped when a field is added or changes meaning).
#define SKIDSTEER_TIRE_CONTRACT_VERSION 2  // 2: the integer kind

typedef enum {
  SKIDSTEER_TIRE_NUMBER = 0,  // a decimal number (strtod), "inf" where not finite-only
  SKIDSTEER_TIRE_CHOICE = 1,  // one word of `choices`
  SKIDSTEER_TIRE_INTEGER = 2, // a whole number within [low, high]
} skidsteerTireAttributeKind;

// One attribute.  A number is valid when it lies in [low, high] (an open end
// excludes the bound) and, if `finite`, is finite; `rule` is the sentence the
// compile-time error gives when it does not.
typedef struct {
  const char* name;          // the <config key="..."> of the attribute
  const char* symbol;        // the thesis's symbol, "" if none
  int kind;                  // skidsteerTireAttributeKind
  double default_value;      // number: the value when unset (NaN: see default_text)
  const char* default_text;  // the default as documentation says it ("from floor", "inf")
  double low;                // number: lower bound
  double high;               // number: upper bound (inf: none)
  int low_open;              // 1: low itself is invalid
  int high_open;             // 1: high itself is invalid
  int finite;                // 1: inf is invalid
  const char* choices;       // choice: the allowed words, space-separated
  const char* unit;          // SI unit, "" for a ratio or a choice
  const char* rule;          // what a valid value is, for error messages
  const char* source;        // provenance: the thesis's equation, section, or "assumed"
} skidsteerTireAttribute;

// A floor the plugin knows by name: the friction set of the `floor` attribute.
typedef struct {
  const char* name;
  double mu_static;
  double mu_kinetic;
  const char* source;
} skidsteerTireFloor;

// The layout of plugin_state: per wheel (body order) per direction (x, then y)
// `nstate_direction` numbers, of which `deflection`, `velocity` and `stuck` are
// the indices.
typedef struct {
  int version;            // SKIDSTEER_TIRE_CONTRACT_VERSION
  int ndirection;         // 2: longitudinal x, lateral y
  int nstate_direction;   // numbers per wheel and direction
  int deflection;         // s, m
  int velocity;           // v_c, m/s
  int stuck;              // 1 sticking, 0 slipping
  int nsensor_wheel;      // tire_forces sensor values per wheel: [N, f_x, f_y]
} skidsteerTireLayout;

// The tables: each returns its row count and points *rows at the first row.
SKIDSTEER_TIRE_EXPORT int skidsteer_tire_attributes(const skidsteerTireAttribute** rows);
SKIDSTEER_TIRE_EXPORT int skidsteer_tire_floors(const skidsteerTireFloor** rows);
SKIDSTEER_TIRE_EXPORT const skidsteerTireLayout* skidsteer_tire_layout(void);

#endif  // SKIDSTEER_PLUGIN_TIRE_TIRE_CONTRACT_H_
