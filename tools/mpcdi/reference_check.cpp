// SPDX-License-Identifier: GPL-3.0-or-later
// Reads an MPCDI package with the VESA / Scalable Display reference reader (github.com/scaredyfish/MPCDI, BSD,
// MPCDI 1.0 only) and prints what it found, one line per buffer and region; exit status 1 and the reader's
// error where it refuses the file. tests/core/test_mpcdi_1_0.py runs it where LAPIG_MPCDI_REFERENCE_CHECK names
// the built program. To build (the SDK's CMake is old: the policy minimum and -fPIC are needed):
//   git clone https://github.com/scaredyfish/MPCDI sdk && mkdir sdk/build && cd sdk/build
//   cmake .. -DCMAKE_POLICY_VERSION_MINIMUM=3.5 -DCMAKE_POSITION_INDEPENDENT_CODE=ON -DCMAKE_C_FLAGS=-fPIC \
//            -DCMAKE_CXX_FLAGS="-fPIC -w" && make -j2
//   S=../src; g++ -std=c++11 -w -I$S -I$S/Base -I$S/IO -I$S/Container -I$S/Creators -I$S/Utils \
//     -I../ThirdParty/tinyxml2 reference_check.cpp -Llib -lmpcdi -Wl,-rpath,$PWD/lib -o reference_check
// The reader reads gammaEmbedded but does not keep it (its own "todo"): the gamma is not printed.
#include <iostream>
#include "mpcdiReader.h"
#include "mpcdiProfile.h"
#include "mpcdiDisplay.h"
#include "mpcdiBuffer.h"
#include "mpcdiRegion.h"
#include "mpcdiFileSet.h"
#include "mpcdiErrorHelper.h"

int main(int argc, char **argv) {
  if (argc != 2) {
    std::cerr << "usage: reference_check FILE.mpcdi" << std::endl;
    return 2;
  }
  mpcdi::Profile *profile = new mpcdi::Profile();
  mpcdi::Reader *reader = mpcdi::Reader::CreateReader();
  mpcdi::MPCDI_Error err = reader->Read(argv[1], profile);
  if (MPCDI_FAILED(err)) {
    std::cout << "refused " << err << ": " << mpcdi::ErrorHelper::GetLastError() << std::endl;
    return 1;
  }
  std::cout << "level " << profile->GetLevel() << " profile " << profile->GetProfileType() << std::endl;
  mpcdi::Display *display = profile->GetDisplay();
  for (auto b = display->GetBufferBegin(); b != display->GetBufferEnd(); ++b) {
    mpcdi::Buffer *buffer = b->second;
    std::cout << "buffer " << buffer->GetId() << " " << buffer->GetXresolution() << "x" << buffer->GetYresolution()
              << std::endl;
    for (auto r = buffer->GetRegionBegin(); r != buffer->GetRegionEnd(); ++r) {
      mpcdi::Region *region = r->second;
      mpcdi::FileSet *files = region->GetFileSet();
      mpcdi::GeometryWarpFile *warp = files->GetGeometryWarpFile();
      mpcdi::AlphaMap *alpha = files->GetAlphaMap();
      std::cout << "region " << region->GetId() << " " << region->GetXresolution() << "x"
                << region->GetYresolution() << " warp " << warp->GetSizeX() << "x" << warp->GetSizeY()
                << " first " << (*warp)(0, 0).r << " " << (*warp)(0, 0).g << " alpha " << alpha->GetSizeX() << "x"
                << alpha->GetSizeY() << " first " << (int)(*alpha)(0, 0, 0)
                << " beta " << (files->GetBetaMap() ? "yes" : "no")
                << " distortion " << (files->GetDistortionMap() ? "yes" : "no") << std::endl;
    }
  }
  return 0;
}
