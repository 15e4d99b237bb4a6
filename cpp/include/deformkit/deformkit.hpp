#pragma once
// Umbrella header.
#include "deformkit/barr.hpp"
#include "deformkit/barr_deformer.hpp"
#include "deformkit/deformer.hpp"
#include "deformkit/frame.hpp"
#include "deformkit/profile.hpp"
#include "deformkit/simple_deform.hpp"
#include "deformkit/stack.hpp"
