// YAML -> Params loading lives here (see yaml_params.hpp).
