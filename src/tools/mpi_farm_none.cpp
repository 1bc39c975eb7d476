// dsmplan built without MPI: the farm is never active (see "MPI" in dsmplan/tools.hpp).
#include "dsmplan/mpi_farm.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

MpiFarm::MpiFarm(int&, char**&) {}
MpiFarm::~MpiFarm() = default;
BoundedEngine MpiFarm::master() const { return {}; }
void MpiFarm::serve(const SimplifyJobOptions&) const {}
void MpiFarm::release_workers() const {}

}  // namespace dsmplan
