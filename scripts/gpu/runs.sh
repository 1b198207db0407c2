# Sourced by lease.sh and lease-train.sh: the lease's runs and the shipped model each one trains.
# shellcheck disable=SC2034  # read by the scripts that source it
declare -A run_model=([t2m]=emdm-t2m-web [a2m]=emdm-a2m-web [ddim]=diffusion-t2m-web)
run_names="t2m, a2m or ddim"
run_re="$(IFS='|'; echo "${!run_model[*]}")"   # t2m|a2m|ddim (in some order): for RUN-VARIANT patterns
