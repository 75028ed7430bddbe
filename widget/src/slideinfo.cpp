#include "slideinfo_p.h"

#include <QtCore/QFile>

#include "magnification_p.h"

double IrisSlideInfo::effectiveObjectivePower() const
{
    return iris::effectiveObjectivePower(objectivePower, mppX, mppY);
}

namespace IrisWidget {

static QString fromStd(const std::string &s)
{
    return QString::fromUtf8(s.data(), qsizetype(s.size()));
}

IrisSlideInfo toSlideInfo(const iris::SlideInfo &info)
{
    IrisSlideInfo out;
    out.path = QFile::decodeName(QByteArray::fromStdString(info.path));
    out.vendor = fromStd(info.vendor);
    out.width = info.width;
    out.height = info.height;
    out.levels.reserve(qsizetype(info.levels.size()));
    for (const iris::LevelInfo &level : info.levels)
        out.levels.append(IrisSlideLevel{level.width, level.height, level.downsample, level.synthetic});
    out.mppX = info.mppX;
    out.mppY = info.mppY;
    out.objectivePower = info.objectivePower;
    for (const auto &[name, value] : info.properties)
        out.properties.insert(fromStd(name), fromStd(value));
    for (const std::string &name : info.associatedImages)
        out.associatedImages.append(fromStd(name));
    return out;
}

} // namespace IrisWidget
