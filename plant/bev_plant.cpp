// SPDX-License-Identifier: BSD-3-Clause
#include "plant/bev_plant.hpp"

namespace ehpt::plant {

template class EvPlant<MapMachine>;

}  // namespace ehpt::plant
